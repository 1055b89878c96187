"""Turn a :class:`~redservo.scenario.Scenario` into runnable objects, and run it.

See ``docs/scenarios.md`` for the file format. Defaults applied here:
``rho = 0.1``, ``lam = 0.5`` (1/s), ``dt = 0.04`` (s), ``max_iterations = 1000``,
``tolerance = 1e-3``, camera 640x480 with ``px = py = 600``, depth ``current``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import RedservoError, ScenarioError
from redservo.features import (
    CylinderFeature,
    LineFeature,
    MomentFeatures,
    PointFeature,
    SphereFeature,
)
from redservo.features.base import Feature
from redservo.limits import JointLimits
from redservo.redundancy import Law, make_law
from redservo.redundancy.gain import AdaptiveGain
from redservo.robots import Robot, make_robot
from redservo.scenario import Scenario, pose_from_table
from redservo.scene import (
    ConstantVelocity,
    Cylinder,
    Line,
    PointSet,
    Scene,
    SceneObject,
    Sphere,
    Static,
    Trajectory,
    Waypoints,
)
from redservo.simulation import Occlusion, SimulationOptions, SimulationResult, simulate
from redservo.spatial import inverse, make_transform
from redservo.task import TaskTerm, VisualTask

__all__ = ["DEFAULT_MARGIN", "Experiment", "build", "run_scenario"]

DEFAULT_MARGIN = 0.01
"""Default ``[robot] margin``: the shield keeps joints 1 % of their range off the hard limits."""


@dataclass
class Experiment:
    """Everything needed to simulate one scenario."""

    scenario: Scenario
    robot: Robot
    scene: Scene
    task: VisualTask
    law: Law
    q0: FloatArray
    limits: JointLimits
    options: SimulationOptions
    camera: Camera
    actuator: Any = None
    """Actuator model (``[actuators]``), or None for the ideal robot."""

    def safety_options(self) -> dict[str, Any]:
        """The scenario's ``[control]`` safety settings (shield, robust, scaling) for any law."""
        ctl = self.scenario.data["control"]
        return {k: ctl[k] for k in ("shield", "robust", "scaling") if k in ctl}

    def run(
        self,
        *,
        method: str | None = None,
        law_options: Mapping[str, Any] | None = None,
        progress: Callable[[int], None] | None = None,
        **option_overrides: Any,
    ) -> SimulationResult:
        """Simulate; ``method``/``law_options`` replace the scenario's law, and keyword
        ``option_overrides`` replace fields of :class:`SimulationOptions`."""
        law = self.law
        if method is not None or law_options is not None:
            name = method or self.scenario.method
            opts = (
                dict(law_options)
                if law_options is not None
                else (
                    dict(self.scenario.data["control"].get("options", {}))
                    if name == self.scenario.method
                    else {}
                )
            )
            law = make_law(name, **{**self.safety_options(), **opts})
        options = replace(self.options, **option_overrides) if option_overrides else self.options
        return simulate(
            self.robot,
            self.scene,
            self.task,
            law,
            self.q0,
            options=options,
            camera=self.camera,
            limits=self.limits,
            actuator=self.actuator,
            progress=progress,
        )


def _arr(sc: Scenario, key: str, value: Any, shape: tuple[int, ...] | None = None) -> FloatArray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise sc.error(key, f"expected numbers, got {value!r}") from None
    if shape is not None and a.shape != shape:
        raise sc.error(key, f"expected shape {shape}, got {a.shape} from {value!r}")
    if not np.all(np.isfinite(a)):
        raise sc.error(key, "values must be finite")
    return a


def _robot(sc: Scenario) -> tuple[Robot, JointLimits, FloatArray]:
    r = sc.data["robot"]
    try:
        robot = make_robot(r["model"], **r.get("options", {}))
    except RedservoError as exc:
        raise sc.error("robot.options", str(exc)) from None
    n = robot.n
    if "q_min" in r or "q_max" in r:
        q_min = _arr(sc, "robot.q_min", r.get("q_min", robot.q_min), (n,))
        q_max = _arr(sc, "robot.q_max", r.get("q_max", robot.q_max), (n,))
        try:
            robot.set_limits(q_min, q_max)
        except RedservoError as exc:
            raise sc.error("robot.q_min", str(exc)) from None
    for key in ("qdot_max", "qddot_max"):
        if key in r:
            try:
                robot.set_limits(**{key: r[key]})
            except RedservoError as exc:
                raise sc.error(f"robot.{key}", str(exc)) from None
    rho = float(r.get("rho", 0.1))
    try:
        limits = robot.limits(rho, margin=float(r.get("margin", DEFAULT_MARGIN)))
    except RedservoError as exc:
        key = "robot.margin" if getattr(exc, "argument", None) == "margin" else "robot.rho"
        raise sc.error(key, str(exc)) from None
    if "q0" in r and "start_pose" in r:
        raise sc.error("robot", "give either q0 or start_pose, not both")
    if "q0" in r:
        q0 = _arr(sc, "robot.q0", r["q0"], (n,))
        bad = np.flatnonzero((q0 < limits.q_min) | (q0 > limits.q_max))
        if bad.size:
            i = int(bad[0])
            raise sc.error(
                "robot.q0",
                f"q0[{i}] = {q0[i]:.6g} is outside the joint limits "
                f"[{limits.q_min[i]:.6g}, {limits.q_max[i]:.6g}] of joint {robot.joint_names[i]!r}",
            )
    elif "start_pose" in r:
        bMc = pose_from_table(r["start_pose"], "robot.start_pose", sc)
        guess = _arr(sc, "robot.q_guess", r["q_guess"], (n,)) if "q_guess" in r else None
        try:
            q0 = robot.ikine(bMc, guess)
        except RedservoError as exc:
            raise sc.error("robot.start_pose", str(exc)) from None
    else:
        raise sc.error("robot.q0", "missing: give q0 (joint positions) or start_pose (camera pose)")
    return robot, limits, q0


def _trajectory(sc: Scenario, where: str, obj: Mapping[str, Any], wMo0: FloatArray) -> Trajectory:
    motion = obj.get("motion")
    if motion is None:
        return Static(wMo0)
    kind = motion.get("kind", "static")
    if kind == "static":
        return Static(wMo0)
    if kind == "constant_velocity":
        v = _arr(sc, f"{where}.motion.velocity", motion.get("velocity", [0, 0, 0]), (3,))
        w = _arr(
            sc, f"{where}.motion.angular_velocity", motion.get("angular_velocity", [0, 0, 0]), (3,)
        )
        return ConstantVelocity(wMo0, v, w)
    if kind == "waypoints":
        times = _arr(sc, f"{where}.motion.times", motion.get("times"))
        k = times.shape[0] if times.ndim == 1 else -1
        tr = _arr(sc, f"{where}.motion.translations", motion.get("translations"), (k, 3))
        rv = _arr(
            sc, f"{where}.motion.rotvecs", motion.get("rotvecs", np.zeros((k, 3)).tolist()), (k, 3)
        )
        # Offsets are world-frame translations of the origin and rotations about the origin.
        poses = np.stack([np.eye(4)] * k)
        for i in range(k):
            poses[i][:3, :3] = make_transform(rotvec=rv[i])[:3, :3] @ wMo0[:3, :3]
            poses[i][:3, 3] = wMo0[:3, 3] + tr[i]
        try:
            return Waypoints(times, poses)
        except RedservoError as exc:
            raise sc.error(f"{where}.motion", str(exc)) from None
    raise sc.error(
        f"{where}.motion.kind",
        f"unknown motion {kind!r}; allowed: static, constant_velocity, waypoints",
    )


def _scene(sc: Scenario, robot: Robot, q0: FloatArray) -> Scene:
    bMc0 = robot.fkine(q0)
    objects: list[SceneObject] = []
    for i, o in enumerate(sc.data.get("objects", [])):
        where = f"objects[{i}]"
        if "pose" in o and "pose_in_camera" in o:
            raise sc.error(where, "give either pose or pose_in_camera, not both")
        if "pose_in_camera" in o:
            wMo0 = bMc0 @ pose_from_table(o["pose_in_camera"], f"{where}.pose_in_camera", sc)
        else:
            wMo0 = pose_from_table(o.get("pose", {}), f"{where}.pose", sc)
        traj = _trajectory(sc, where, o, wMo0)
        kind, name = o["kind"], o["name"]
        try:
            if kind == "points":
                pts = _arr(sc, f"{where}.points", o.get("points", [[0.0, 0.0, 0.0]]))
                objects.append(PointSet(name, pts, trajectory=traj))
            elif kind == "sphere":
                center = _arr(sc, f"{where}.center", o.get("center", [0, 0, 0]), (3,))
                objects.append(Sphere(name, float(o.get("radius", 0.05)), center, trajectory=traj))
            elif kind == "cylinder":
                axis = _arr(sc, f"{where}.axis", o.get("axis", [0, 1, 0]), (3,))
                point = _arr(sc, f"{where}.point", o.get("point", [0, 0, 0]), (3,))
                objects.append(
                    Cylinder(name, float(o.get("radius", 0.05)), axis, point, trajectory=traj)
                )
            else:  # line
                point = _arr(sc, f"{where}.point", o.get("point", [0, 0, 0]), (3,))
                direction = _arr(sc, f"{where}.direction", o.get("direction", [0, 1, 0]), (3,))
                objects.append(Line(name, point, direction, trajectory=traj))
        except ScenarioError:
            raise
        except RedservoError as exc:
            raise sc.error(where, str(exc)) from None
    try:
        return Scene(objects)
    except RedservoError as exc:
        raise sc.error("objects", str(exc)) from None


def _desired_poses(sc: Scenario, scene: Scene, ref: str) -> dict[str, FloatArray]:
    """``c*Mo`` for every object: the desired pose is given relative to the reference object."""
    table = sc.data["task"]["desired_pose"]
    cdMref = pose_from_table(table, "task.desired_pose", sc)
    wMref = scene.wMo(ref, 0.0)
    return {name: cdMref @ inverse(wMref) @ scene.wMo(name, 0.0) for name in scene.names}


def _features(
    sc: Scenario, scene: Scene, desired: Mapping[str, FloatArray] | None
) -> tuple[list[TaskTerm], list[int]]:
    """The task terms, and for each the index of the ``[[features]]`` entry it came from."""
    terms: list[TaskTerm] = []
    entry_of: list[int] = []
    for i, f in enumerate(sc.data["features"]):
        where = f"features[{i}]"
        obj = scene.object(f["object"])
        kind = f["kind"]
        feats: list[Feature]
        try:
            if kind == "point":
                if not isinstance(obj, PointSet):
                    raise sc.error(f"{where}.kind", "a point feature needs a 'points' object")
                pts = np.asarray(obj.points, dtype=float)
                idx = [int(f["index"])] if "index" in f else list(range(pts.shape[0]))
                for j in idx:
                    if not 0 <= j < pts.shape[0]:
                        raise sc.error(f"{where}.index", f"must be in [0, {pts.shape[0] - 1}]")
                feats = [PointFeature(pts[j]) for j in idx]
            elif kind == "sphere":
                if not isinstance(obj, Sphere):
                    raise sc.error(f"{where}.kind", "a sphere feature needs a 'sphere' object")
                feats = [SphereFeature(obj.radius, obj.center, variant=f.get("variant", "exact"))]
            elif kind == "cylinder":
                if not isinstance(obj, Cylinder):
                    raise sc.error(f"{where}.kind", "a cylinder feature needs a 'cylinder' object")
                feats = [CylinderFeature(obj.radius, obj.axis, obj.point)]
            elif kind == "line":
                if not isinstance(obj, Line):
                    raise sc.error(f"{where}.kind", "a line feature needs a 'line' object")
                feats = [LineFeature(obj.point, obj.direction)]
            else:  # moments
                if not isinstance(obj, PointSet):
                    raise sc.error(f"{where}.kind", "moment features need a 'points' object")
                if desired is None:
                    raise sc.error("task.desired_pose", "moment features need task.desired_pose")
                opts = {}
                if "rotation_features" in f:
                    opts["rotation_features"] = f["rotation_features"]
                feats = [MomentFeatures.at_desired_pose(obj.points, desired[obj.name], **opts)]
        except ScenarioError:
            raise
        except RedservoError as exc:
            raise sc.error(where, str(exc)) from None
        terms.extend(TaskTerm(feat, obj.name) for feat in feats)
        entry_of.extend(i for _ in feats)
    return terms, entry_of


def _selection(sc: Scenario, terms: list[TaskTerm], entry_of: list[int]) -> FloatArray | None:
    """Selection matrix ``C`` (m, k) from the ``features[i].components`` lists, or None.

    ``components`` keeps only the listed components (0-based, in the feature's
    order, e.g. ``[0, 1, 2, 3]`` = xn, yn, an, α of the moments) in the task:
    ``e1 = C (s - s*)`` and ``J1 = C L J``, while the whole ``s`` is still
    measured and logged. When an entry expands to several terms (the point
    features of a point set) the list applies to each of them. An explicit
    selection replaces the automatic combination matrix of :class:`VisualTask`.

    Args:
        sc: The scenario (for error messages).
        terms: The task terms, in order.
        entry_of: For each term, the index of the ``[[features]]`` entry it came from.
    """
    entries = sc.data["features"]
    if not any("components" in f for f in entries):
        return None
    rows: list[int] = []
    offset = 0
    for term, i in zip(terms, entry_of, strict=True):
        size = term.feature.size
        comps = entries[i].get("components", list(range(size)))
        key = f"features[{i}].components"
        if not comps or not all(isinstance(c, int) and not isinstance(c, bool) for c in comps):
            raise sc.error(key, f"expected a non-empty list of integers, got {comps!r}")
        if len(set(comps)) != len(comps) or not all(0 <= c < size for c in comps):
            raise sc.error(
                key,
                f"components must be distinct indices in [0, {size - 1}] "
                f"(the feature has {size} components), got {comps!r}",
            )
        rows.extend(offset + c for c in sorted(comps))
        offset += size
    return np.asarray(np.eye(offset)[rows])


def build(sc: Scenario) -> Experiment:
    """Build the robot, scene, task, law and options of a scenario.

    Raises:
        ScenarioError: anything in the file is inconsistent (names the key).
    """
    robot, limits, q0 = _robot(sc)
    scene = _scene(sc, robot, q0)
    task_t = sc.data.get("task", {})
    ref = sc.data["features"][0]["object"]
    desired = _desired_poses(sc, scene, ref) if "desired_pose" in task_t else None
    terms, entry_of = _features(sc, scene, desired)
    C = _selection(sc, terms, entry_of)
    depth = task_t.get("depth", "current")
    try:
        if desired is not None:
            task = VisualTask.from_desired_poses(terms, desired, depth=depth, C=C)
        elif "desired" in task_t:
            k = sum(t.feature.size for t in terms)
            s_star = _arr(sc, "task.desired", task_t["desired"], (k,))
            task = VisualTask(terms, s_star, depth=depth, C=C)
        else:
            raise sc.error(
                "task", "give task.desired_pose (c*Mo of the target) or task.desired (s*)"
            )
    except ScenarioError:
        raise
    except RedservoError as exc:
        raise sc.error("task", str(exc)) from None
    ctl = sc.data["control"]
    try:
        safety = {k: ctl[k] for k in ("shield", "robust", "scaling") if k in ctl}
        law = make_law(ctl["method"], **safety, **ctl.get("options", {}))
    except RedservoError as exc:
        arg = getattr(exc, "argument", None)
        raise sc.error(
            f"control.{arg}" if arg in ("scaling",) else "control.options", str(exc)
        ) from None
    actuator = None
    if "actuators" in sc.data:
        from redservo.hardware.actuators import ActuatorModel

        try:
            actuator = ActuatorModel.from_table(sc.data["actuators"])
        except RedservoError as exc:
            raise sc.error(getattr(exc, "argument", None) or "actuators", str(exc)) from None
    cam_t = sc.data.get("camera", {})
    try:
        camera = Camera(**cam_t) if cam_t else Camera()
    except RedservoError as exc:
        raise sc.error("camera", str(exc)) from None
    options = _options(sc, robot)
    # The task must be valid at the start: a target behind the camera is a scenario error.
    try:
        task.evaluate(scene, robot.fkine(q0), robot.jacobian(q0), 0.0)
    except RedservoError as exc:
        raise sc.error(
            "objects", f"the task is not valid at the start configuration: {exc}"
        ) from None
    return Experiment(sc, robot, scene, task, law, q0, limits, options, camera, actuator)


def _options(sc: Scenario, robot: Robot) -> SimulationOptions:
    ctl, sim = sc.data["control"], sc.data.get("simulation", {})
    kw: dict[str, Any] = {
        "lam": _gain(sc, ctl),
        "dt": float(ctl.get("dt", 0.04)),
        "rho": float(sc.data["robot"].get("rho", 0.1)),
    }
    for key in (
        "max_iterations",
        "tolerance",
        "noise_std",
        "seed",
        "depth_scale",
        "feedforward",
        "image_margin_px",
        "check_image",
        "stop_at_convergence",
        "min_margin",
    ):
        if key in sim:
            kw[key] = sim[key]
    if "qdot_max" in sim:
        q = sim["qdot_max"]
        kw["qdot_max"] = tuple(float(v) for v in q) if isinstance(q, list) else float(q)
    if "eMc_error" in sim:
        robot_eMc = robot.eMc
        kw["eMc_model"] = robot_eMc @ pose_from_table(sim["eMc_error"], "simulation.eMc_error", sc)
    if "occlusion" in sc.data:
        kw["occlusion"] = Occlusion(**sc.data["occlusion"])
    try:
        return SimulationOptions(**kw)
    except RedservoError as exc:
        raise sc.error("simulation", str(exc)) from None


def _gain(sc: Scenario, ctl: Mapping[str, Any]) -> float | AdaptiveGain:
    """``[control] lam`` (1/s), or the adaptive gain ``[control] gain = {zero, inf, slope}``."""
    if "gain" not in ctl:
        return float(ctl.get("lam", 0.5))
    if "lam" in ctl:
        raise sc.error("control.gain", "give either lam (constant) or gain (adaptive), not both")
    g = ctl["gain"]
    missing = [k for k in ("zero", "inf", "slope") if k not in g]
    if missing:
        raise sc.error(f"control.gain.{missing[0]}", "missing: gain needs zero, inf and slope")
    try:
        return AdaptiveGain(float(g["zero"]), float(g["inf"]), float(g["slope"]))
    except RedservoError as exc:
        raise sc.error(f"control.gain.{getattr(exc, 'argument', '') or 'zero'}", str(exc)) from None


def run_scenario(
    sc: Scenario,
    *,
    method: str | None = None,
    progress: Callable[[int], None] | None = None,
) -> SimulationResult:
    """Build and run a scenario (optionally with another method)."""
    return build(sc).run(method=method, progress=progress)
