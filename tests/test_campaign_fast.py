"""The compiled campaign loop (redservo.campaign.fastloop): identical rows, and its fallbacks.

The first test in a fresh checkout compiles the loop (about a minute, then cached on disk).
"""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("numba", reason="the compiled campaign loop needs numba (redservo[fast])")

from redservo import METHODS
from redservo.campaign import draw_sample, fastloop, load_campaign, run_campaign
from redservo.campaign.engine import FAST_PATH
from redservo.campaign.fastloop import campaign_law, fast_run, fast_summary
from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario

COMPILED = tuple(m for m in METHODS if m not in ("predictive", "qp-goal"))
"""The methods with a compiled step (``predictive`` and ``qp-goal`` run on the Python step:
docs/predictive.md)."""


def _exact(value: Any) -> Any:
    """Floats by their repr (bit for bit, NaN equal to NaN), other values as they are."""
    return repr(value) if isinstance(value, float) else value


def _same_rows(a: tuple[dict[str, Any], ...], b: tuple[dict[str, Any], ...]) -> bool:
    return [{k: _exact(v) for k, v in r.items()} for r in a] == [
        {k: _exact(v) for k, v in r.items()} for r in b
    ]


_NOT_MEASURED_BY_THE_LOOP = ("min_manipulability", "min_singular_value")
"""Summary fields the compiled loop leaves None ("not measured": the singularity margin needs
the task Jacobian's SVD at every step, which only the object path keeps); no row carries them."""


def _same_summary(a: dict[str, Any], b: dict[str, Any]) -> bool:
    a, b = ({k: v for k, v in d.items() if k not in _NOT_MEASURED_BY_THE_LOOP} for d in (a, b))

    def walk(v: Any) -> Any:
        if isinstance(v, dict):
            return {k: walk(x) for k, x in v.items()}
        if isinstance(v, list):
            return [walk(x) for x in v]
        return _exact(v)

    return bool(walk(a) == walk(b))


def _variant(name: str, *sets: str) -> Any:
    d = load_campaign(name)
    return replace(d, scenario=apply_overrides(d.scenario, list(sets))) if sets else d


def test_campaign_rows_are_those_of_the_object_path(capsys: pytest.CaptureFixture[str]) -> None:
    """cm01-gaze, every method, the shield off (sample 1 of seed 0 hits a limit): the same rows
    bit for bit, every run on the compiled loop."""
    d = _variant("cm01-gaze", "control.shield=false")
    fast = run_campaign(d, samples=2, methods=COMPILED, workers=1, progress=False)
    assert "object path" not in capsys.readouterr().err  # no run fell back, not even qp
    slow = run_campaign(d, samples=2, methods=COMPILED, workers=1, progress=False, fast=False)
    assert len(fast.rows) == 2 * len(COMPILED)
    assert _same_rows(fast.rows, slow.rows)
    outcomes = {r["outcome"] for r in fast.rows}
    assert {"converged", "joint_limit"} <= outcomes
    assert any(r["flags"] for r in fast.rows)


def test_campaign_json_records_the_engine_of_each_run(tmp_path: Path) -> None:
    """campaign.json and campaign.md say which runs took the compiled loop (issue 18)."""
    import json

    d = load_campaign("cm01-gaze")
    run_campaign(d, samples=2, methods=["gpm", "qp"], workers=1, progress=False, out=tmp_path)
    meta = json.loads((tmp_path / "campaign.json").read_text())
    assert meta["engine"] == {"gpm": {"compiled loop": 2}, "qp": {"compiled loop": 2}}
    assert (
        "Engine: 4 run(s) computed by this call on the compiled loop."
        in (tmp_path / "campaign.md").read_text()
    )
    slow = run_campaign(d, samples=1, methods=["gpm"], workers=1, progress=False, fast=False)
    assert list(slow.engines["gpm"].values()) == [1]
    assert "compiled loop" not in slow.engines["gpm"]


def test_panda_rows_with_a_combination_matrix_and_lost_targets() -> None:
    """A DH robot, four points with C (m = 6 of k = 8), runs that lose the target or reach the
    iteration cap: the same rows on both paths."""
    d = load_campaign("panda-near-limits")
    methods = ["classical", "gpm-auto", "iterative", "directional", "qp"]
    fast = run_campaign(d, samples=2, methods=methods, workers=1, progress=False)
    slow = run_campaign(d, samples=2, methods=methods, workers=1, progress=False, fast=False)
    assert _same_rows(fast.rows, slow.rows)
    assert {"target_lost", "max_iterations"} <= {r["outcome"] for r in fast.rows}


def test_urdf_panda_rows_are_those_of_the_object_path(capsys: pytest.CaptureFixture[str]) -> None:
    """The Panda from its URDF (a chain of fixed transforms and joint axes, kind 2 of the
    loop), every compiled method of the shipped campaign: no fallback, the same rows bit for
    bit."""
    pytest.importorskip("pinocchio", reason="URDF robots are loaded by Pinocchio")
    d = load_campaign("panda-urdf-near-limits")
    methods = [m for m in d.methods if m in COMPILED]
    fast = run_campaign(d, samples=2, methods=methods, workers=1, progress=False)
    assert "object path" not in capsys.readouterr().err
    slow = run_campaign(d, samples=2, methods=methods, workers=1, progress=False, fast=False)
    assert len(fast.rows) == 2 * len(methods)
    assert _same_rows(fast.rows, slow.rows)
    exp = build(draw_sample(d, 0, 0).scenario)
    assert type(exp.robot).__name__ == "URDFRobot"
    assert fastloop.experiment_reason(exp) is None


_TURNING = (
    'objects[0].motion={kind="waypoints", times=[0.0, 2.0, 5.0], '
    "translations=[[0.0, 0.0, 0.0], [0.02, -0.03, 0.01], [0.05, 0.0, -0.02]], "
    "rotvecs=[[0.0, 0.0, 0.0], [0.05, -0.1, 0.2], [0.1, 0.05, -0.3]]}"
)
"""A motion for panda-near-limits' square: moving and turning (the Rodrigues branch)."""


@pytest.mark.parametrize(
    ("name", "sets"),
    [
        ("cm01-humanoid-tracking", ()),
        ("panda-near-limits", (_TURNING, 'simulation.feedforward="known"')),
        ("panda-near-limits", (_TURNING, "simulation.max_iterations=120")),
    ],
)
def test_moving_targets_and_known_feedforward_rows(
    name: str, sets: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    """Targets on waypoints (translated, and turned), with and without the known
    feed-forward (with a combination matrix C on the Panda), every method: no fallback and
    the rows of the object path bit for bit."""
    d = _variant(name, *sets)
    methods = [m for m in d.methods if m in COMPILED]  # not predictive's Python step
    fast = run_campaign(d, samples=2, methods=methods, workers=1, progress=False)
    assert "object path" not in capsys.readouterr().err
    slow = run_campaign(d, samples=2, methods=methods, workers=1, progress=False, fast=False)
    assert len(fast.rows) == 2 * len(methods)
    assert _same_rows(fast.rows, slow.rows)
    exp = build(draw_sample(d, 0, 0).scenario)
    assert type(exp.scene.object(exp.task.terms[0].target).trajectory).__name__ == "Waypoints"


@pytest.mark.parametrize("sets", [(), ("simulation.depth_scale=1.3", "control.shield=false")])
def test_moment_rows_are_those_of_the_object_path(
    sets: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    """The six moment features of mc05-joint-limits (and with a depth error, the shield
    off), every method: no fallback, the same rows bit for bit."""
    d = _variant("mc05-joint-limits", *sets)
    methods = [m for m in d.methods if m in COMPILED]  # not predictive's Python step
    fast = run_campaign(d, samples=2, methods=methods, workers=1, progress=False)
    assert "object path" not in capsys.readouterr().err
    slow = run_campaign(d, samples=2, methods=methods, workers=1, progress=False, fast=False)
    assert len(fast.rows) == 2 * len(methods)
    assert _same_rows(fast.rows, slow.rows)
    assert len({r["outcome"] for r in fast.rows}) >= 2


def test_waypoint_poses_are_those_of_the_scene() -> None:
    """The loop's waypoint pose and Rodrigues formula equal Waypoints.pose and
    rotvec_to_matrix bit for bit (tiny and large angles, before, on and after the
    waypoints)."""
    import numpy as np

    from redservo.kernels import loop_task
    from redservo.scene import Waypoints
    from redservo.spatial import make_transform, rotvec_to_matrix

    rng = np.random.default_rng(3)
    for _ in range(2000):
        r = rng.normal(size=3) * 10.0 ** rng.uniform(-10, 0.5)
        assert np.array_equal(loop_task._rotvec_matrix(r), rotvec_to_matrix(r))
    k = 6
    times = np.cumsum(rng.uniform(0.1, 2.0, k))
    poses = [make_transform(rotvec=rng.normal(size=3), t=rng.normal(size=3)) for _ in range(k)]
    w = Waypoints(times, np.stack(poses))
    for t in [*rng.uniform(times[0] - 1.0, times[-1] + 1.0, 2000), *times]:
        got = loop_task._waypoint_pose(w.times, w.poses, w._rotvecs, k, float(t))
        assert np.array_equal(got, w.pose(float(t))), t


@pytest.mark.parametrize(
    "sets",
    [
        (),
        ("simulation.qdot_saturation=0.05", "simulation.depth_scale=1.3", "control.robust=false"),
        ("control.shield=false", "simulation.check_image=false", "control.lam=1.5"),
    ],
)
def test_summaries_and_flag_counts_match(sets: tuple[str, ...]) -> None:
    """The whole typed summary (flag counts and first iterations included) of every method on
    the CM01 start: actuator saturation, a depth error, the plain paper laws, no image check."""
    exp = build(apply_overrides(load_scenario("cm01-gaze"), list(sets)))
    flags: set[str] = set()
    for method in COMPILED:
        summary, path = fast_run(exp, method, None)
        assert path == FAST_PATH, (method, path)
        assert summary is not None
        ref = exp.run(method=method).summary
        assert _same_summary(summary.to_dict(), ref.to_dict()), method
        flags |= set(summary.flags)
    assert len(flags) >= 3  # several kinds of flags were compared


def test_uncovered_set_ups_fall_back_and_say_why(capsys: pytest.CaptureFixture[str]) -> None:
    """Feature noise and secondary-first scaling run on the object path, with one stderr line
    per reason, and give the rows of fast=False."""
    d = replace(
        load_campaign("cm01-gaze"),
        scenario=apply_overrides(
            load_campaign("cm01-gaze").scenario, ["simulation.noise_std=1e-4"]
        ),
    )
    fast = run_campaign(d, samples=1, methods=["classical", "gpm"], workers=1, progress=False)
    err = capsys.readouterr().err
    assert "2 run(s) of classical, gpm on the object path" in err and "feature noise" in err
    slow = run_campaign(
        d, samples=1, methods=["classical", "gpm"], workers=1, progress=False, fast=False
    )
    assert _same_rows(fast.rows, slow.rows)
    exp = build(load_scenario("cm01-gaze"))
    law = campaign_law(exp, "gpm", {"scaling": "secondary-first"})
    assert fastloop.fast_reason(exp, law) == "scaling = 'secondary-first'"
    assert fast_summary(exp, law) is None
    noisy = build(apply_overrides(load_scenario("cm01-gaze"), ["simulation.noise_std=1e-4"]))
    assert fastloop.experiment_reason(noisy) == "feature noise"
    assert fast_run(noisy, "classical", None) == (None, "feature noise")


def test_a_run_the_law_would_abort_goes_to_the_object_path(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """When the loop reports that the law would raise (or anything goes wrong in it), the run
    is done again on the object path, which records what happens there."""
    exp = build(load_scenario("cm01-gaze"))
    monkeypatch.setattr(fastloop, "_run_loop", lambda *_a: (3, 0, -1, 1))
    assert fast_run(exp, "classical", None) == (None, "the object path would raise")

    def broken(*_a: object) -> None:
        raise RuntimeError("a bug in the loop")

    monkeypatch.setattr(fastloop, "_run_loop", broken)
    assert fast_run(exp, "sns", None) == (None, "the compiled loop raised RuntimeError")
    d = load_campaign("cm01-gaze")
    rows = run_campaign(d, samples=1, methods=["sns"], workers=1, progress=False).rows
    ref = run_campaign(d, samples=1, methods=["sns"], workers=1, progress=False, fast=False).rows
    assert _same_rows(rows, ref)


def test_the_loop_as_plain_python_gives_the_compiled_numbers(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The loop's own body run uncompiled (``py_func``, its callees compiled) logs the same
    numbers as the compiled loop: one source for both."""
    from redservo.campaign import loop_kernel

    exp = build(apply_overrides(load_scenario("cm01-gaze"), ["simulation.max_iterations=12"]))
    for method in ("iterative-smooth", "qp"):
        law = campaign_law(exp, method, None)
        compiled = fast_summary(exp, law)
        kernel: Any = loop_kernel.closed_loop
        with monkeypatch.context() as m:
            m.setattr(loop_kernel, "closed_loop", kernel.py_func)
            plain = fast_summary(exp, law)
        assert compiled is not None and plain is not None
        assert _same_summary(compiled.to_dict(), plain.to_dict())
        assert compiled.iterations == 12


_OPTIONS: dict[str, list[dict[str, Any]]] = {
    "gpm-auto": [{}, {"alpha_max": 5.0, "critical_rule": "current"}],
    "iterative": [{}, {"max_levels": 1, "constraint_rcond": 0.01}],
    "iterative-smooth-e2": [{}, {"alpha": 0.5}],
    "directional": [{}, {"use_joint_limits": False}],
    "sns": [{}, {"v_max": 0.05, "margin": 0.02}],
    "large-projection": [{}, {"projector": "norm"}],
}


def _random_step(rng: Any, lim: Any) -> tuple[Any, ...]:
    """A control step's inputs: J1 full rank, rank-deficient or nearly singular; q with joints
    in their bands; a previous command within the velocity limits."""
    import numpy as np

    n = lim.n
    m = int(rng.choice([2, 3, 6]))
    J1 = rng.normal(size=(m, n))
    kind = rng.integers(3)
    if kind == 1 and m > 1:
        J1[-1] = J1[0] * rng.uniform(-2, 2)
    elif kind == 2:
        U, s, Vt = np.linalg.svd(J1, full_matrices=False)
        s[-1] = s[0] * 10.0 ** rng.uniform(-9, -3)
        J1 = (U * s) @ Vt
    e1 = rng.normal(size=m) * 10.0 ** rng.uniform(-3, 0)
    near = rng.random(n) < 0.5
    margin = rng.uniform(0.002, 0.15, n) * lim.range
    upper = rng.random(n) < 0.5
    q = np.where(upper, lim.q_max - margin, lim.q_min + margin)
    q = np.where(near, q, lim.q_min + rng.uniform(0.2, 0.8, n) * lim.range)
    prev = rng.uniform(-0.8, 0.8, n) * lim.qdot_max
    lam, dt = float(rng.choice([0.3, 1.0, 5.0])), float(rng.choice([0.04, 0.08]))
    return np.ascontiguousarray(J1), e1, q, prev, lam, dt


@pytest.mark.parametrize("robot", ["afma6", "panda"])
def test_step_commands_and_flags_match_the_law_objects(robot: str) -> None:
    """Every compiled law (options varied, robust on and off) on random steps: the loop's
    command is the law's bit for bit, and its flag mask holds exactly the law's events."""
    import numpy as np

    from redservo import make_law
    from redservo.campaign.fastloop import _flag_bits, _law_args
    from redservo.errors import InfeasibleError
    from redservo.kernels.sensed import ABORT_INFEASIBLE, law_bits_sec
    from redservo.kernels.step import LAW_IDS
    from redservo.redundancy.packs import limits_pack
    from redservo.robots import make_robot

    rng = np.random.default_rng(7)
    lim = make_robot(robot).limits(0.1)
    lp = limits_pack(lim)
    limits = (lp.rows, lp.has_v, lp.has_a, np.array(lim.q_min), np.array(lim.q_max))
    raised: set[int] = set()
    for method in LAW_IDS:
        for opts in _OPTIONS.get(method, [{}]):
            for robust in (True, False):
                law = make_law(method, robust=robust, **opts)
                args = _law_args(law, lim.n)
                for _ in range(25):
                    J1, e1, q, prev, lam, dt = _random_step(rng, lim)
                    sim = (lam, dt, 1e-3, True, np.ones(lim.n), False, False)
                    z = np.zeros(lim.n)
                    qd, bits, _, abort = law_bits_sec(
                        J1, e1, e1, False, q, prev, z, False, args, limits, sim, z[:0]
                    )
                    try:
                        res = law(J1=J1, e1=e1, q=q, limits=lim, lam=lam, dt=dt, qdot_prev=prev)
                    except InfeasibleError:
                        assert abort == ABORT_INFEASIBLE, method
                        continue
                    assert abort == 0
                    assert np.array_equal(qd, res.qdot), (method, opts, robust)
                    assert bits == _flag_bits(res.diagnostics.events), (method, opts, robust)
                    raised.add(bits)
    assert len(raised) >= 8  # many combinations of flags were met


def test_no_shipped_campaign_falls_back(capsys: pytest.CaptureFixture[str]) -> None:
    """Every shipped campaign, every method with a compiled step, two samples: every run on
    the compiled loop (no fallback line, every row's path note the compiled loop's), among
    obstacles too (panda-posts: ``qp`` and ``sns`` with their damper rows); the
    ``predictive`` method runs on the Python step, and the campaign says so in one line."""
    from redservo.campaign.definition import shipped_campaigns

    for name in shipped_campaigns():
        d = load_campaign(name)
        if "urdf" in d.scenario.name and importlib.util.find_spec("pinocchio") is None:
            continue  # URDF robots are loaded by Pinocchio (checked where it is installed)
        for i in range(2):
            exp = build(draw_sample(d, 0, i).scenario)
            for method in (m for m in d.methods if m in COMPILED):
                law = campaign_law(exp, method, d.method_options.get(method))
                assert fastloop.fast_reason(exp, law) is None, (name, method)
                summary, path = fast_run(exp, method, d.method_options.get(method))
                assert path == FAST_PATH and summary is not None, (name, i, method, path)
        run_campaign(d, samples=1, methods=COMPILED, workers=1, progress=False)
        assert "object path" not in capsys.readouterr().err, name
    d = load_campaign("panda-near-limits")
    run_campaign(d, samples=1, methods=["predictive"], workers=1, progress=False)
    err = capsys.readouterr().err
    line = "1 run(s) of predictive on the object path, not the compiled loop: method "
    assert line + "'predictive' has no compiled step" in err


def test_known_feedforward_kernel_is_the_controllers() -> None:
    """The loop's known feed-forward equals redservo.control.feedforward.known_feedforward
    bit for bit along the humanoid's target motion (t = 0 clipped, on and between the
    waypoints, after the last), and says "not ok" where the object path raises (the target
    behind the camera), which hands the run to the object path."""
    import numpy as np

    from redservo.campaign.looppack import scene_args, task_args
    from redservo.control.feedforward import known_feedforward
    from redservo.errors import GeometryError
    from redservo.kernels import loop_task
    from redservo.spatial import inverse, make_transform

    exp = build(load_scenario("cm01-humanoid-tracking"))
    scene, task, dt = scene_args(exp), task_args(exp), exp.options.dt
    bMc = exp.robot.fkine(exp.q0)
    cMw = loop_task.inverse(bMc) @ scene[0]
    compared = 0
    for t in (0.0, 0.02, 0.04, 1.0, 2.0, 3.3, 5.0, 12.98, 13.0, 16.0, 20.0):
        ff, ok = loop_task.known_feedforward(cMw, scene, task, t, dt)
        try:
            ref = known_feedforward(exp.task, exp.scene, bMc, t, dt)
        except GeometryError:  # late in the motion the point is behind the resting camera
            assert not ok, t
            continue
        assert ok and np.array_equal(ff, ref), t
        compared += 1
    assert compared >= 5
    away = bMc @ make_transform(rotvec=[np.pi, 0.0, 0.0])
    with pytest.raises(GeometryError):
        known_feedforward(exp.task, exp.scene, away, 1.0, dt)
    assert not loop_task.known_feedforward(inverse(away) @ scene[0], scene, task, 1.0, dt)[1]
