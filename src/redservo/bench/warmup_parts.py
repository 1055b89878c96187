"""What each group of ``redservo warmup`` runs (:data:`redservo.bench.warmup.GROUPS`).

Every function runs a piece of the library the way a user's command does, so that numba
compiles the kernels with the argument types the commands use: each law through the public
API (:func:`law`), each shipped scenario for a few iterations (:func:`scenario`, with the
sphere variants and the realistic camera), the Controller's compiled step
(:func:`compiled_steps`), each shipped campaign's reachability search (:func:`search`) and
its compiled loop (:func:`campaign`). A part's runner takes its name and ``note``, which
prints a line (e.g. a part skipped and why).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np

__all__ = [
    "HEAVY_SCENARIOS",
    "Note",
    "campaign",
    "campaign_parts",
    "compiled_steps",
    "feature_variants",
    "law",
    "law_parts",
    "scenario",
    "scenario_parts",
    "search",
]

Note = Callable[[str], None]
"""Prints a note of a group (e.g. a part skipped and why)."""


def law_parts() -> tuple[str, ...]:
    from redservo import METHODS

    return tuple(METHODS)


def law(method: str, note: Note) -> None:
    from redservo import JointLimits, make_law

    rng = np.random.default_rng(0)
    lim = JointLimits(-np.ones(7), np.ones(7), qdot_max=1.0, qddot_max=5.0)
    J1, e1, q = rng.normal(size=(6, 7)), rng.normal(size=6), rng.uniform(-0.5, 0.5, 7)
    law = make_law(method)
    first = law(J1=J1, e1=e1, q=q, limits=lim, lam=0.5, dt=0.04)
    law(J1=J1, e1=e1, q=q, limits=lim, lam=0.5, dt=0.04, qdot_prev=first.qdot)


_SPHERES = "sphere variants"
_CAMERA = "realistic camera"
_DISTORTED = "panda-eye-to-hand image sensor"
HEAVY_SCENARIOS = (_CAMERA, _DISTORTED)
"""The scenario parts that compile an image pipeline of their own (28-47 kernels each, 18-21 s
on the quiet machine, where the other scenario parts load the Controller's chain in a second)."""


def scenario_parts() -> tuple[str, ...]:
    from redservo.scenario import shipped_scenarios

    return (*shipped_scenarios(), _SPHERES, _CAMERA, _DISTORTED)


def scenario(name: str, note: Note) -> None:
    from redservo.experiment.build import build
    from redservo.scenario import load_scenario

    if name == _SPHERES:
        feature_variants()
        return
    if name == _CAMERA:
        realistic_camera(note)
        return
    if name == _DISTORTED:
        distorted_lens(note)
        return
    try:
        exp = build(load_scenario(name))
    except ImportError as exc:  # an optional extra (e.g. Pinocchio for a URDF robot)
        note(f"{name} skipped: {' '.join(str(exc).split())}")
        return
    exp.run(max_iterations=3)


def realistic_camera(note: Note) -> None:
    """The image pipeline behind ``--camera realistic`` (exposure, tracker, PnP depths,
    latency compensation, the image border): a panda-near-limits sample whose dot leaves the
    image (110 periods, ``qp``; 5 of ``wln``, whose step runs compiled) and a few periods of
    mc05-joint-limits' moments."""
    from dataclasses import replace

    from redservo.campaign import draw_sample, load_campaign
    from redservo.experiment.build import build
    from redservo.experiment.camera_presets import camera_overrides
    from redservo.scenario import apply_overrides

    for name, sample, iterations in (("panda-near-limits", 11, 110), ("mc05-joint-limits", 0, 5)):
        defn = load_campaign(name)
        scenario = apply_overrides(defn.scenario, camera_overrides("realistic"))
        try:
            exp = build(draw_sample(replace(defn, scenario=scenario), 0, sample).scenario)
        except ImportError as exc:  # OpenCV (redservo[vision]) renders and tracks the dots
            note(f"{_CAMERA} skipped: {' '.join(str(exc).split())}")
            return
        exp.run(method="qp", max_iterations=iterations)
        if name == "panda-near-limits":  # wln's compiled step with the loop's Jacobian, and
            exp.run(method="wln", max_iterations=5)  # the points brought to the present


def distorted_lens(note: Note) -> None:
    """The image sensor through a distorted lens (panda-eye-to-hand's calibrated camera with
    ``sensor.kind = "image"``): whole frames rendered and undistorted, which the realistic
    camera's composed frames do not compile."""
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    scenario = apply_overrides(load_scenario("panda-eye-to-hand"), ['sensor.kind="image"'])
    try:
        exp = build(scenario)
    except ImportError as exc:  # OpenCV (redservo[vision]) tracks the dots
        note(f"{_DISTORTED} skipped: {' '.join(str(exc).split())}")
        return
    exp.run(max_iterations=3)


def feature_variants() -> None:
    """Every sphere variant's measure and interaction (a shipped scenario uses one; the
    reproduction's CM01 eq. 27 runs use the others)."""
    from redservo.features.sphere import SPHERE_VARIANTS, SphereFeature, SphereVariant
    from redservo.spatial import make_transform

    cMo = make_transform(t=(0.02, -0.01, 0.6))
    for variant in SPHERE_VARIANTS:
        feature = SphereFeature(0.05, variant=cast(SphereVariant, variant))
        s, inv_depth = feature.measure(cMo)
        feature.interaction(s, inv_depth)


def compiled_steps(part: str, note: Note) -> None:
    from redservo.bench.cases import bench_cases

    cases = {c.name: c for c in bench_cases(scaling=())}
    controllers(cases)
    iterations(cases)


def iterations(cases: dict[str, Any]) -> None:
    """The campaign loop's iteration called from Python (:mod:`redservo.bench.sensed`:
    ``redservo bench``'s compiled path, the tests of ``qp``'s loop step): its kernels take
    the types of a Python call, not those :func:`closed_loop` passes them."""
    from redservo.bench.sensed import sensed_iteration
    from redservo.redundancy import make_law

    for name in ("afma6-4points", "panda-6d-free"):
        c = cases[name]
        for method in ("classical", "qp"):
            law = make_law(method)
            it = sensed_iteration(c.robot, c.scene, c.task, law, limits=c.limits, lam=0.5, dt=0.04)
            it(c.q, it(c.q))


def controllers(cases: dict[str, Any]) -> None:
    """The Controller's compiled step with its own kinematics (Afma6, DH) and with a given
    Jacobian (what the simulator and the servo loop pass)."""
    from redservo.control import Controller, Measurement
    from redservo.redundancy import make_law

    for name in ("afma6-4points", "panda-6d-free"):
        c = cases[name]
        ctl = Controller(c.robot, c.task, make_law("classical"), c.limits, lam=0.5, dt=0.04)
        bMc, J = c.robot.kinematics(c.q)
        c.task.evaluate(c.scene, bMc, J, 0.0)  # the object path's task kernel (points_task)
        meas = Measurement(*c.task.measure(c.scene, bMc, 0.0))
        prev = ctl.step(c.q, meas, 0.0, qdot_prev=None).qdot.copy()
        ctl.step(c.q, meas, 0.0, qdot_prev=prev, J=J)


def campaign_parts() -> tuple[str, ...]:
    from redservo.campaign.definition import shipped_campaigns

    return tuple(shipped_campaigns())


def built_sample(name: str, note: Note) -> Any:
    """The first sample of a shipped campaign, built (None: an optional extra is missing,
    said in a note)."""
    from redservo.campaign.definition import load_campaign
    from redservo.campaign.sampling import draw_sample
    from redservo.experiment.build import build

    try:
        return build(draw_sample(load_campaign(name), 0, 0).scenario)
    except ImportError as exc:
        note(f"{name} skipped: {' '.join(str(exc).split())}")
        return None


def search(name: str, note: Note) -> None:
    """The reachability search of a campaign's samples (kinematics and the ideal sensor's
    task error: no law, so it compiles beside the first part); among obstacles also the
    goal's clearance test (:func:`redservo.campaign.reach_obstacles.goal_clearance`: the
    compiled distances' ``measure_plan``, which the predictive law's goal search calls too)."""
    from redservo.campaign.reach import compile_search, goal_clearance

    exp = built_sample(name, note)
    if exp is not None:
        compile_search(exp)
        clear = goal_clearance(exp)
        if clear is not None:
            clear(np.array(exp.q0, dtype=float))


def campaign(name: str, note: Note) -> None:
    from redservo.campaign.definition import load_campaign
    from redservo.campaign.fastloop import campaign_law, fast_reason, fast_summary

    exp = built_sample(name, note)
    if exp is None:
        return
    defn = load_campaign(name)
    for method in defn.methods:
        law = campaign_law(exp, method, defn.method_options.get(method))
        if fast_reason(exp, law) is None:
            fast_summary(exp, law)
