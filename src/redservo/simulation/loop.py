"""Closed-loop simulation of a visual servo with a redundancy-based control law.

The loop, at every iteration k (time ``t = k dt``):

1. the **sensor** measures the features at the true camera pose ``bMc = fkine(q)``
   (:class:`~redservo.sensors.IdealSensor` by default; an image sensor renders and
   detects);
2. the :class:`~redservo.Controller` (built by :func:`simulation_controller` from the
   options) turns the measurement into the command: the task builds ``e1`` and ``J1`` with
   the controller's model (depth estimate, hand-eye calibration), the **objectives**
   (occlusion avoidance, joint-limit force, user functions) add their joint commands into
   the law's ``secondary`` (they and the ``known`` feed-forward see the scene through a
   :class:`~redservo.control.SceneContext`), and the law, a pure function of
   ``(J1, e1, q, limits, λ, dt, ..., q̇_prev)``, returns the command within the
   velocity/acceleration limits and (shield on) the position limits, then saturated
   (``options.qdot_max``);
3. the robot moves: ``q ← q + q̇ dt`` (ideal), or through an **actuator** model (lag,
   delay, saturation, encoder noise); the law then sees the encoder reading.

The real joint limits are hard: when a step would cross one (by more than
``LIMIT_TOLERANCE``, the roundoff of a step commanded exactly onto a limit), the
run stops at that iteration with outcome ``joint_limit`` (the step is not
applied), as a real robot's safety stop would. Other outcomes: ``converged`` (``‖e1‖ <
tolerance``), ``max_iterations``, ``target_lost`` (a feature is invalid, behind the
camera, or leaves the image), ``feature_lost`` (the image sensor lost a feature for too
many frames), ``occluded`` and ``collision`` (with ``options.collision`` measuring
obstacles or self pairs: the smallest distance between a link and an obstacle or another
link is logged at every step, and a distance <= 0 m ends the run). Every stateful part (law, sensor, actuator) is reset at
the start of each run, so two identical runs give identical logs.

Units: seconds, metres, radians; ``λ`` in 1/s.
"""

from __future__ import annotations

import copy
import sys
from collections.abc import Callable, Sequence
from typing import Any, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.collision.tally import DistanceTally
from redservo.control import Controller, Measurement, SceneContext
from redservo.control.avoidance import CollisionAvoidance
from redservo.control.manipulability import SingularityMargin
from redservo.control.objectives import CallableObjective, Objective, OcclusionAvoidance
from redservo.errors import GeometryError
from redservo.kernels.blas import one_blas_thread
from redservo.limits import JointLimits
from redservo.records import LogBuffer, Outcome, RunSummary, SimulationLog, summarize
from redservo.records.result import SimulationResult
from redservo.redundancy.base import Law
from redservo.robots.base import Robot
from redservo.scene import Scene
from redservo.sensors import FrameNoise, IdealSensor, Sensor, SensorReading
from redservo.sensors.flags import sensor_flags
from redservo.simulation.loop_image import ImageCheck
from redservo.simulation.loop_image import _in_image as _in_image  # its former home
from redservo.simulation.options import SimulationOptions
from redservo.task import TaskState, VisualTask

__all__ = ["LIMIT_TOLERANCE", "Actuator", "SimulationResult", "simulate", "simulation_controller"]

LIMIT_TOLERANCE = 1e-9
"""A step ending within this distance (m or rad) beyond a real limit is floating-point
roundoff of a step commanded onto the limit: it lands on the limit instead of counting
as a crossing. The same tolerance as :meth:`JointLimits.check`."""


class Actuator(Protocol):
    """A joint actuator model (e.g. :class:`redservo.hardware.actuators.ActuatorModel`)."""

    def reset(self, q0: ArrayLike) -> None: ...

    def step(
        self, q: ArrayLike, qdot_cmd: ArrayLike, dt: float
    ) -> tuple[FloatArray, FloatArray]: ...

    def encoder(self, q: ArrayLike) -> FloatArray: ...


def simulation_controller(
    robot: Robot,
    task: VisualTask,
    law: Law,
    options: SimulationOptions,
    *,
    limits: JointLimits | None = None,
    secondary: Callable[[TaskState, FloatArray, float], FloatArray | None] | None = None,
    objectives: Sequence[Objective] = (),
) -> Controller:
    """The :class:`~redservo.Controller` :func:`simulate` drives, built from its options.

    Its model robot is ``robot`` with ``options.eMc_model`` as the hand-eye calibration
    (a copy; ``robot`` itself when there is no calibration error); its objectives are, in
    this order, ``secondary`` (a user function ``f(state, q, t)``), the occlusion avoidance
    of ``options.occlusion`` and ``objectives``; its gain, period, feed-forward, depth
    factor, output saturation and camera-motion limit are the options'.

    Args:
        robot: The true robot.
        task: The visual task.
        law: The control law.
        options: The simulation's options.
        limits: Joint limits given to the law (default: the robot's, with ``options.rho``).
        secondary: Optional ``f(state, q, t) -> (n,)`` extra joint command.
        objectives: Further objectives (:mod:`redservo.control.objectives`).
    """
    model = robot
    if options.eMc_model is not None:
        model = copy.copy(robot)
        model.eMc = options.eMc_model
    objs: list[Objective] = []
    if secondary is not None:
        objs.append(CallableObjective(secondary))
    if options.occlusion is not None:
        objs.append(OcclusionAvoidance(options.occlusion))
    coll = options.collision
    if coll is not None and coll.enabled and coll.avoid and coll.active:
        objs.append(CollisionAvoidance(coll))
    objs.extend(objectives)
    return Controller(
        model,
        task,
        law,
        limits if limits is not None else robot.limits(options.rho),
        lam=options.lam,
        dt=options.dt,
        objectives=objs,
        feedforward=options.feedforward,
        depth_scale=options.depth_scale,
        qdot_saturation=options.qdot_max,
        compensate_latency=options.compensate_latency,
        image_motion=options.image_motion,
        collision=coll,
    )


def _lost_outcome(reading: SensorReading) -> Outcome:
    return "feature_lost" if reading.reason.startswith("feature_lost") else "target_lost"


def simulate(
    robot: Robot,
    scene: Scene,
    task: VisualTask,
    law: Law,
    q0: ArrayLike,
    *,
    options: SimulationOptions | None = None,
    camera: Camera | None = None,
    limits: JointLimits | None = None,
    secondary: Callable[[TaskState, FloatArray, float], FloatArray | None] | None = None,
    objectives: Sequence[Objective] = (),
    sensor: Sensor | None = None,
    actuator: Actuator | None = None,
    progress: Callable[[int], None] | None = None,
) -> SimulationResult:
    """Run the closed loop from ``q0``; see the module docstring.

    Args:
        robot: The true robot (its ``eMc`` is the true hand-eye transform).
        scene: Objects and their motion.
        task: The visual task.
        law: A control law (:func:`redservo.make_law`); reset at the start.
        q0: (n,) start configuration, within the limits.
        options: :class:`SimulationOptions` (defaults if None).
        camera: The image for ``target_lost`` and a law's image bounds (default :class:`Camera`).
        limits: Joint limits given to the law (default: the robot's, with ``options.rho``:
            position, velocity and acceleration limits).
        secondary: Optional ``f(state, q, t) -> (n,)`` extra joint command passed to the law.
        objectives: Further secondary objectives (:mod:`redservo.control.objectives`).
        sensor: Where the features come from (default :class:`~redservo.sensors.IdealSensor`).
        actuator: Joint actuator model (default: ideal, ``q + q̇ dt``).
        progress: Optional callback called with the iteration index.

    Returns:
        :class:`SimulationResult` with the outcome, the typed summary and the log.

    Raises:
        JointLimitError: ``q0`` is outside the limits.
    """
    opt = options or SimulationOptions()
    lim = limits or robot.limits(opt.rho)
    q = lim.check(q0, "q0").copy()
    ctrl = simulation_controller(
        robot, task, law, opt, limits=lim, secondary=secondary, objectives=objectives
    )
    run = _Run(robot, scene, ctrl, opt, camera or Camera(), sensor or IdealSensor(), actuator)
    ctrl.reset()
    run.sensor.reset()
    if actuator is not None:
        actuator.reset(q)
    buf = LogBuffer(opt.max_iterations, robot.n, task.k, task.m)
    outcome: Outcome = "max_iterations"
    limit_hit: dict[str, int] | None = None
    qdot_prev = np.zeros(robot.n)  # the robot starts at rest
    with one_blas_thread():  # the compiled steps: one BLAS thread (kernels/blas.py)
        for it in range(opt.max_iterations):
            end, qdot = run.iteration(it, q, qdot_prev, buf)
            if end is not None:
                outcome = end
                break
            assert qdot is not None
            if actuator is None:
                q_next = q + qdot * opt.dt
            else:
                q_next, _ = actuator.step(q, qdot, opt.dt)
            crossed = np.flatnonzero(
                (q_next < lim.q_min - LIMIT_TOLERANCE) | (q_next > lim.q_max + LIMIT_TOLERANCE)
            )
            if crossed.size:
                outcome = "joint_limit"
                limit_hit = {"axis": int(crossed[0]), "iteration": it}
                break
            qdot_prev = qdot
            # A step commanded exactly onto a limit lands on it (roundoff is not a crossing).
            q = np.clip(q_next, lim.q_min, lim.q_max)
            if progress is not None:
                progress(it)
    log = buf.to_log(robot.joint_names, task.names)
    summary = run.summary(log, outcome, limit_hit)
    return SimulationResult(outcome, summary, log, None, ctrl.engine, ctrl.engine_reason)


class _Run:
    """The parts of one simulated run and its iteration (sense, control, log)."""

    def __init__(
        self,
        robot: Robot,
        scene: Scene,
        ctrl: Controller,
        opt: SimulationOptions,
        camera: Camera,
        sensor: Sensor,
        actuator: Actuator | None,
    ) -> None:
        self.robot, self.scene, self.ctrl, self.opt = robot, scene, ctrl, opt
        self.camera, self.sensor, self.actuator = camera, sensor, actuator
        bind = getattr(ctrl.law, "bind_camera", None)  # the predictive law's image bounds
        if bind is not None:
            bind(camera)
        track = getattr(ctrl.law, "bind_tracker", None)  # and its camera-motion limit
        if track is not None:
            track(_tracking_gate(sensor), _frame_rate(sensor))
        self.frames = getattr(ctrl.law, "observe_dots", None)  # its target pose by PnP
        self.rng = np.random.default_rng(opt.seed)
        self.noise = FrameNoise(opt.noise_std, self.rng)  # a held frame keeps its noise
        self.targets = sorted({term.target for term in ctrl.task.terms})
        self.in_view = ImageCheck(scene, self.targets, camera, opt.image_margin_px)
        """The check that every target stays in view (:mod:`redservo.simulation.loop_image`)."""
        # The true Jacobian serves the controller when its model is the true robot.
        self.true_model = ctrl.robot is robot and actuator is None
        coll = opt.collision
        self.collision = coll if coll is not None and coll.active else None
        self.tally = None if self.collision is None else DistanceTally(self.collision.d_influence)
        """The run's distances per pair kind (:mod:`redservo.collision.tally`)."""
        self.margin = SingularityMargin()
        """The run's distance to a task singularity (:mod:`redservo.control.manipulability`)."""
        self.contact: dict[str, Any] | None = None
        """``{"pair", "distance", "iteration"}`` of the contact that ended the run."""

    def summary(
        self, log: SimulationLog, outcome: Outcome, limit_hit: dict[str, int] | None
    ) -> RunSummary:
        """The run's summary (:func:`~redservo.records.summarize`) with its contact, its
        distances per pair kind and its singularity margin."""
        opt = self.opt
        return summarize(
            log,
            outcome,
            self.ctrl.limits,
            limit_hit,
            dt=opt.dt,
            min_margin=opt.min_margin,
            collision=self.contact,
            distances=None if self.tally is None else self.tally.fields(),
            singularity=self.margin.fields(),
        )

    def closest(self, it: int, q: FloatArray, t: float) -> tuple[float, str] | None:
        """The smallest distance (m) and its pair at the true ``q``, None when not measured;
        records the contact when the distance is <= 0."""
        if self.collision is None:
            return None
        pd = self.collision.measure(self.robot, q, t)
        if self.tally is not None:
            self.tally.add(pd)
        d, pair = pd.closest()
        if d <= 0.0:
            self.contact = {"pair": pair, "distance": d, "iteration": it}
        return d, pair

    def iteration(
        self, it: int, q: FloatArray, qdot_prev: FloatArray, buf: LogBuffer
    ) -> tuple[Outcome | None, FloatArray | None]:
        """Sense, control and log iteration ``it``: ``(outcome, None)`` ends the run, else
        ``(None, command)``."""
        opt, ctrl, lim = self.opt, self.ctrl, self.ctrl.limits
        t = it * opt.dt
        act = self.actuator
        q_meas = q if act is None else np.clip(act.encoder(q), lim.q_min, lim.q_max)
        bMc, J_true = self.robot.kinematics(q, check_limits=False)
        J = J_true if self.true_model else ctrl.robot.jacobian(q_meas, check_limits=False)
        closest = self.closest(it, q, t)
        if self.contact is not None:
            return "collision", None
        reading = self.sensor.read(ctrl.task, self.scene, bMc, t)
        if reading.s is None:
            return _lost_outcome(reading), None
        if self.frames is not None and reading.dots is not None:
            self.frames(reading.dots, t - (t if reading.stamp is None else reading.stamp))
        s = self.noise(reading)
        meas = Measurement(s, tuple(reading.inv_depth), reading.stamp)
        if opt.check_image and not self.in_view(bMc, t):
            return "target_lost", None  # an object left the image
        try:
            step = ctrl.step(
                q_meas, meas, t, qdot_prev=qdot_prev, J=J, context=SceneContext(self.scene, bMc)
            )
        except GeometryError:
            if ctrl.stage != "task":
                raise
            return "target_lost", None
        if step.stop is not None:
            return cast(Outcome, step.stop), None
        assert step.diagnostics is not None
        state, qdot = step.state, step.qdot
        diagnostics = sensor_flags(step.diagnostics, reading)  # the image sensor's no-pose
        buf.append(t, q, qdot, J_true @ qdot, state, lim, diagnostics, closest)
        self.margin.add(state.J1)
        err = float(np.linalg.norm(state.e1))
        if err < opt.tolerance and (opt.stop_at_convergence or it == opt.max_iterations - 1):
            return "converged", None
        return None, qdot


def _frame_rate(sensor: Sensor) -> float | None:
    """The frame rate (Hz) of the camera whose timing wraps ``sensor``
    (:class:`redservo.sensors.timing.TimedSensor`), None: a frame every period."""
    rate = getattr(getattr(sensor, "timing", None), "rate", None)
    return None if rate is None else float(rate)


def _tracking_gate(sensor: Sensor) -> float | None:
    """The gate (pixels) of ``sensor``'s dot tracker, None without one (the ideal sensor:
    the image pipeline is not imported for it). A camera's timing wraps the sensor
    (:class:`redservo.sensors.timing.TimedSensor`, which holds it in ``.sensor``): the gate
    is the wrapped sensor's. Any image sensor counts, the MuJoCo camera
    (:class:`redservo.physics.camera.MujocoCamera`) included: an image sensor exists only
    once :mod:`redservo.vision.sensor` is imported."""
    inner = getattr(sensor, "sensor", None)  # through a camera's timing wrapper
    sensor = sensor if inner is None else inner
    if "redservo.vision.sensor" not in sys.modules:
        return None
    from redservo.vision.sensor import tracking_gate_px

    return tracking_gate_px(sensor)
