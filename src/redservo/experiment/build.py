"""Turn a validated :class:`~redservo.scenario.Scenario` into runnable objects, and run it.

:func:`build` reads the scenario's schema (:class:`redservo.schema.ScenarioSpec`, where
every default lives) and builds through the registries: the robot by name
(:func:`redservo.robots.make_robot`) or from a URDF file, each object and feature by its
spec (:mod:`redservo.schema.scene`, which calls :func:`redservo.features.make_feature`),
the law by name (:func:`redservo.make_law`). The geometry is checked here: ``q0`` within
the limits, every observed object in front of the camera and in the image at the start.
:meth:`Experiment.controller` gives the scenario's :class:`~redservo.Controller`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.collision.shapes import Obstacle
from redservo.control import Controller
from redservo.errors import RedservoError, ScenarioError
from redservo.experiment.camera import mounted_robot, scenario_camera
from redservo.experiment.robot import scenario_robot as _robot
from redservo.experiment.sensor import attach_timing, scenario_sensor
from redservo.experiment.start import attach_collision, check_start
from redservo.limits import JointLimits
from redservo.redundancy import Law, make_law
from redservo.redundancy.gain import AdaptiveGain
from redservo.robots import Robot
from redservo.scenario import Scenario
from redservo.scene import Scene, Static
from redservo.schema.scenario import ScenarioSpec
from redservo.sensors import Sensor
from redservo.sensors.timing import CameraTiming, timed
from redservo.simulation import Occlusion, SimulationOptions, SimulationResult, simulate
from redservo.simulation.loop import Actuator, simulation_controller
from redservo.spatial import inverse
from redservo.task import TaskTerm, VisualTask

__all__ = ["Experiment", "SharedParts", "build", "build_robot", "run_scenario", "scenario_law"]


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
    sensor: Sensor | None = None
    actuator: Actuator | None = None
    obstacles: tuple[Obstacle, ...] = ()  # [[obstacles]] (redservo.collision), world frame
    timing: CameraTiming = field(default_factory=CameraTiming)
    """The camera's timing (``[sensor]`` rate, latency, exposure): every run's sensor is seen
    through it (:func:`redservo.sensors.timing.timed`), whoever replaced :attr:`sensor`."""

    def run(
        self,
        *,
        method: str | None = None,
        law_options: Mapping[str, Any] | None = None,
        progress: Callable[[int], None] | None = None,
        **option_overrides: Any,
    ) -> SimulationResult:
        """Simulate; ``method``/``law_options`` replace the scenario's law (the scenario's
        ``control.shield``, ``robust`` and ``scaling`` still apply unless ``law_options``
        sets them), and keyword ``option_overrides`` replace fields of
        :class:`SimulationOptions`. The simulator drives the :meth:`controller` of the same
        arguments."""
        law = self._law(method, law_options)
        options = replace(self.options, **option_overrides) if option_overrides else self.options
        result = simulate(
            self.robot,
            self.scene,
            self.task,
            law,
            self.q0,
            options=options,
            camera=self.camera,
            limits=self.limits,
            sensor=timed(self.sensor, self.timing, options.dt),
            actuator=self.actuator,
            progress=progress,
        )
        result.provenance = self._provenance(method, law_options, options)
        return result

    def controller(
        self,
        *,
        method: str | None = None,
        law_options: Mapping[str, Any] | None = None,
        **option_overrides: Any,
    ) -> Controller:
        """The :class:`~redservo.Controller` a run of this scenario drives, arguments as in
        :meth:`run`: the model robot (with the scenario's hand-eye error), task, law, limits,
        gain, period, occlusion objective, feed-forward, depth factor and saturation. Drive
        it from :class:`~redservo.hardware.ServoLoop` or a loop of your own."""
        options = replace(self.options, **option_overrides) if option_overrides else self.options
        law = self._law(method, law_options)
        return simulation_controller(self.robot, self.task, law, options, limits=self.limits)

    def _law(self, method: str | None, law_options: Mapping[str, Any] | None) -> Law:
        """The scenario's law, or ``method`` with ``law_options`` and the scenario's safety."""
        if method is None and law_options is None:
            return self.law
        ctl = self.scenario.spec.control
        name = method or ctl.method
        if law_options is not None:
            opts = dict(law_options)
        else:
            opts = dict(ctl.options) if name == ctl.method else {}
        safety = {"shield": ctl.shield, "robust": ctl.robust, "scaling": ctl.scaling}
        return make_law(name, **{**safety, **opts})

    def _provenance(
        self, method: str | None, law_options: Mapping[str, Any] | None, options: Any
    ) -> Any:
        """What :meth:`run` ran, for a self-describing run directory (redservo.runs.provenance)."""
        from redservo.runs.provenance import Provenance

        ctl = self.scenario.spec.control
        name = method or ctl.method
        if law_options is None:
            law_options = ctl.options if name == ctl.method else {}
        sc, opts = self.scenario, dict(law_options)
        return Provenance(
            sc.data, sc.source, name, opts, options, self.limits, self.q0.copy(), build, self.robot
        )


def _key(
    sc: Scenario, table: str, exc: RedservoError, fields: Mapping[str, Any], default: str
) -> ScenarioError:
    """A ScenarioError for ``exc`` under ``table.ARGUMENT`` when that key exists, else ``default``."""
    arg = getattr(exc, "argument", None)
    key = f"{table}.{arg}" if arg and arg in fields else default
    return sc.error(key, str(exc))


def _per_joint(sc: Scenario, key: str, value: Any, n: int, *, scalar_ok: bool = True) -> Any:
    if value is None or (scalar_ok and not isinstance(value, list)):
        return value
    if len(value) != n:
        raise sc.error(key, f"expected {n} values (one per joint of the robot), got {len(value)}")
    return np.array(value, dtype=float)


def _limits(sc: Scenario, spec: ScenarioSpec, robot: Robot) -> JointLimits:
    r, n = spec.robot, robot.n
    q_min = _per_joint(sc, "robot.q_min", r.q_min, n)
    q_max = _per_joint(sc, "robot.q_max", r.q_max, n)
    qdot = _per_joint(sc, "robot.qdot_max", r.qdot_max, n)
    qddot = _per_joint(sc, "robot.qddot_max", r.qddot_max, n)
    try:
        robot.set_limits(
            q_min,
            q_max,
            qdot_max="keep" if qdot is None else qdot,
            qddot_max="keep" if qddot is None else qddot,
        )
        return robot.limits(r.rho, margin=r.margin)
    except RedservoError as exc:
        raise _key(sc, "robot", exc, type(r).model_fields, "robot.q_min") from None


def _start(sc: Scenario, spec: ScenarioSpec, robot: Robot, limits: JointLimits) -> FloatArray:
    r, n = spec.robot, robot.n
    if r.q0 is not None:
        q0 = _per_joint(sc, "robot.q0", r.q0, n, scalar_ok=False)
        bad = np.flatnonzero((q0 < limits.q_min) | (q0 > limits.q_max))
        if bad.size:
            i = int(bad[0])
            raise sc.error(
                f"robot.q0[{i}]",
                f"q0[{i}] = {q0[i]:.6g} is outside the joint limits "
                f"[{limits.q_min[i]:.6g}, {limits.q_max[i]:.6g}] of joint {i} "
                f"({robot.joint_names[i]!r}; joints are numbered from 0)",
            )
        return np.asarray(q0, dtype=float)
    assert r.start_pose is not None
    guess = _per_joint(sc, "robot.q_guess", r.q_guess, n, scalar_ok=False)
    try:
        return robot.ikine(r.start_pose.matrix(), guess)
    except RedservoError as exc:
        raise sc.error("robot.start_pose", str(exc)) from None


def _scene(sc: Scenario, spec: ScenarioSpec, robot: Robot, q0: FloatArray) -> Scene:
    bMc0 = robot.fkine(q0)
    objects = []
    for i, o in enumerate(spec.objects):
        if o.pose_in_camera is not None:
            wMo0 = bMc0 @ o.pose_in_camera.matrix()
        elif o.pose_in_effector is not None:  # eye-to-hand: the world is the effector's frame
            wMo0 = o.pose_in_effector.matrix()
        else:
            wMo0 = o.pose.matrix() if o.pose is not None else np.eye(4)
        try:
            traj = o.motion.trajectory(wMo0) if o.motion is not None else Static(wMo0)
        except RedservoError as exc:
            raise sc.error(f"objects[{i}].motion", str(exc)) from None
        try:
            objects.append(o.scene_object(traj))
        except RedservoError as exc:
            raise sc.error(f"objects[{i}]", str(exc)) from None
    return Scene(objects)


def _task(sc: Scenario, spec: ScenarioSpec, scene: Scene) -> VisualTask:
    t = spec.task
    desired = None
    if t.desired_pose is not None:
        ref = spec.features[0].object
        cdMref = t.desired_pose.matrix()
        wMref = scene.wMo(ref, 0.0)
        desired = {name: cdMref @ inverse(wMref) @ scene.wMo(name, 0.0) for name in scene.names}
    terms: list[TaskTerm] = []
    rows: list[int] = []
    for i, f in enumerate(spec.features):
        obj = scene.object(f.object)
        try:
            feats = f.features(obj, desired)
        except RedservoError as exc:
            raise sc.error(f"features[{i}]", str(exc)) from None
        for feat in feats:
            comps = f.components if f.components is not None else range(feat.size)
            offset = sum(term.feature.size for term in terms)
            rows.extend(offset + c for c in sorted(comps))
            terms.append(TaskTerm(feat, obj.name))
    k = sum(term.feature.size for term in terms)
    C = np.eye(k)[rows] if any(f.components is not None for f in spec.features) else None
    try:
        if desired is not None:
            return VisualTask.from_desired_poses(terms, desired, depth=t.depth, C=C)
        return VisualTask(terms, np.array(t.desired, dtype=float), depth=t.depth, C=C)
    except RedservoError as exc:
        raise sc.error("task.desired_pose" if desired is not None else "task", str(exc)) from None


def _options(sc: Scenario, spec: ScenarioSpec, robot: Robot, camera: Camera) -> SimulationOptions:
    ctl, sim = spec.control, spec.simulation
    focal_px = 0.5 * (camera.px + camera.py)  # tolerance_px: ‖e1‖ in pixels
    lam: float | AdaptiveGain = 0.5 if ctl.lam is None else ctl.lam
    if ctl.gain is not None:
        lam = AdaptiveGain(ctl.gain.zero, ctl.gain.inf, ctl.gain.slope)
    qdot_max: float | tuple[float, ...] | None = None
    if isinstance(sim.qdot_saturation, list):
        qdot_max = tuple(
            _per_joint(sc, "simulation.qdot_saturation", sim.qdot_saturation, robot.n).tolist()
        )
    else:
        qdot_max = sim.qdot_saturation
    occ = spec.occlusion
    try:
        return SimulationOptions(
            lam=lam,
            dt=ctl.dt,
            max_iterations=sim.max_iterations,
            tolerance=sim.tolerance if sim.tolerance_px is None else sim.tolerance_px / focal_px,
            rho=spec.robot.rho,
            min_margin=sim.min_margin,
            qdot_max=qdot_max,
            noise_std=sim.noise_std,
            seed=sim.seed,
            depth_scale=sim.depth_scale,
            eMc_model=None if sim.eMc_error is None else robot.eMc @ sim.eMc_error.matrix(),
            feedforward=sim.feedforward,
            image_margin_px=sim.image_margin_px,
            check_image=sim.check_image,
            occlusion=None if occ is None else Occlusion(**occ.model_dump()),
            stop_at_convergence=sim.stop_at_convergence,
            compensate_latency=spec.sensor.compensate_latency,
        )
    except RedservoError as exc:  # pragma: no cover - the schema checks every field
        raise _key(sc, "simulation", exc, type(sim).model_fields, "simulation") from None


def _actuator(sc: Scenario, spec: ScenarioSpec, n: int) -> Actuator | None:
    a = spec.actuators
    if a is None:
        return None
    from redservo.hardware.actuators import ActuatorModel

    names = type(a).MODEL_KEYS
    kwargs = {}
    for key, value in a.model_dump().items():
        if isinstance(value, list):
            value = _per_joint(sc, f"actuators.{key}", value, n)
        kwargs[names.get(key, key)] = value
    try:
        return ActuatorModel(**kwargs)
    except RedservoError as exc:
        raise _key(sc, "actuators", exc, type(a).model_fields, "actuators") from None


class SharedParts(NamedTuple):
    """The parts of an experiment a campaign's samples share, built once from its base
    scenario (:mod:`redservo.campaign.sample_build`): the robot before mounting, its limits,
    the law and the camera."""

    robot: Robot
    limits: JointLimits
    law: Law
    camera: Camera


def scenario_law(spec: ScenarioSpec) -> Law:
    """The ``[control]`` law of a scenario, with its safety options and law options."""
    ctl = spec.control
    return make_law(
        ctl.method, shield=ctl.shield, robust=ctl.robust, scaling=ctl.scaling, **ctl.options
    )


def build_robot(sc: Scenario) -> Robot:
    """Only the scenario's robot, with the file's limit overrides (no scene, task or law).

    Raises:
        ScenarioError: the robot keys are invalid (names the key).
    """
    robot = _robot(sc, sc.spec)
    _limits(sc, sc.spec, robot)
    return robot


def build(
    sc: Scenario, *, robot: Robot | None = None, shared: SharedParts | None = None
) -> Experiment:
    """Build the robot, scene, task, law and options of a scenario.

    Args:
        sc: The scenario.
        robot: Use this robot, as it is, instead of building the scenario's (e.g. a saved
            run's :class:`~redservo.runs.kinematics.LoggedRobot`, already mounted).
        shared: Use these parts, built once from a campaign's base scenario, instead of
            building them (:mod:`redservo.campaign.sample_build`: its samples differ only
            in what the other steps build).

    Raises:
        ScenarioError: anything in the file is invalid or inconsistent (names the key).
    """
    spec = sc.spec
    given = robot is not None and shared is None  # a robot to use as it is
    if shared is not None:
        robot, limits = shared.robot, shared.limits
    else:
        robot = _robot(sc, spec) if robot is None else robot
        limits = _limits(sc, spec, robot)
    if not given:
        robot = mounted_robot(sc, robot)  # camera.mount = "world": the eye-to-hand wrapper
    q0 = _start(sc, spec, robot, limits)
    scene = _scene(sc, spec, robot, q0)
    task = _task(sc, spec, scene)
    law = scenario_law(spec) if shared is None else shared.law
    camera = scenario_camera(sc) if shared is None else shared.camera
    options = _options(sc, spec, robot, camera)
    exp = Experiment(sc, robot, scene, task, law, q0, limits, options, camera)
    exp.sensor = scenario_sensor(sc, camera)
    exp.actuator = _actuator(sc, spec, robot.n)
    exp.obstacles = tuple(o.obstacle() for o in spec.obstacles)
    attach_collision(sc, exp)
    if spec.simulator is not None and spec.simulator.kind == "mujoco":
        from redservo.physics.scenario import attach_mujoco  # heavy: only when asked

        attach_mujoco(exp)
    attach_timing(sc, exp)
    check_start(sc, spec, exp)
    return exp


def run_scenario(
    sc: Scenario,
    *,
    method: str | None = None,
    progress: Callable[[int], None] | None = None,
) -> SimulationResult:
    """Build and run a scenario (optionally with another method)."""
    return build(sc).run(method=method, progress=progress)
