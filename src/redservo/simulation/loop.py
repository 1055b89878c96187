"""Closed-loop simulation of a visual servo with a redundancy-based control law.

The loop, at every iteration k (time ``t = k dt``):

1. the **sensor** measures the features at the true camera pose ``bMc = fkine(q)``
   (:class:`~redservo.sensors.IdealSensor` by default; an image sensor renders and
   detects);
2. the task builds ``e1`` and ``J1`` from the measurement with the controller's model
   (depth estimate, hand-eye calibration);
3. the **objectives** (occlusion avoidance, joint-limit force, user functions) add their
   joint commands into the law's ``secondary``;
4. the law, a pure function of ``(J1, e1, q, limits, λ, dt, ..., q̇_prev)``, returns
   the command, within the velocity/acceleration limits and (shield on) the position
   limits;
5. the robot moves: ``q ← q + q̇ dt`` (ideal), or through an **actuator** model (lag,
   delay, saturation, encoder noise); the law then sees the encoder reading.

The real joint limits are hard: when a step would cross one (by more than
``LIMIT_TOLERANCE``, the roundoff of a step commanded exactly onto a limit), the
run stops at that iteration with outcome ``joint_limit`` (the step is not
applied), as a real robot's safety stop would. Other outcomes: ``converged`` (``‖e1‖ <
tolerance``), ``max_iterations``, ``target_lost`` (a feature is invalid, behind the
camera, or leaves the image), ``feature_lost`` (the image sensor lost a feature for too
many frames) and ``occluded``. Every stateful part (law, sensor, actuator) is reset at
the start of each run, so two identical runs give identical logs.

Units: seconds, metres, radians; ``λ`` in 1/s.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import GeometryError
from redservo.limits import JointLimits
from redservo.redundancy.base import Law
from redservo.robots.base import Robot
from redservo.scene import Scene
from redservo.sensors import IdealSensor, Sensor, SensorReading
from redservo.simulation.objectives import (
    CallableObjective,
    Objective,
    ObjectiveContext,
    OcclusionAvoidance,
    visible_points,
)
from redservo.simulation.options import SimulationOptions
from redservo.simulation.runlog import LogBuffer, SimulationLog
from redservo.simulation.summary import Outcome, RunSummary, summarize
from redservo.task import TaskState, VisualTask

__all__ = ["LIMIT_TOLERANCE", "Actuator", "SimulationResult", "simulate"]

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


@dataclass
class SimulationResult:
    """The outcome, typed summary and log of one run."""

    outcome: Outcome
    summary: RunSummary
    log: SimulationLog
    provenance: Any = field(default=None, repr=False, compare=False)
    """What the run was made from (:class:`redservo.provenance.Provenance`), set by
    :meth:`redservo.experiment.Experiment.run`; None for a bare :func:`simulate`."""

    def save(self, directory: str | Path, *, extra: dict[str, Any] | None = None) -> Path:
        """Write ``summary.json``, ``log.npz``, ``log.csv`` and ``diagnostics.json`` into
        ``directory``, and with a provenance the resolved ``scenario.toml`` and ``run.json``
        (:mod:`redservo.provenance`: ``redservo run DIR/scenario.toml`` re-runs it)."""
        import json

        from redservo.provenance import write_run_files

        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        summary = {**self.summary.to_dict(), **(extra or {})}
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        self.log.save_npz(out / "log.npz")
        self.log.save_csv(out / "log.csv")
        write_run_files(out, self)
        return out


def _saturate(qdot: FloatArray, qdot_max: FloatArray | None) -> FloatArray:
    if qdot_max is None:
        return qdot
    ratio = float(np.max(np.abs(qdot) / qdot_max))
    return qdot / ratio if ratio > 1.0 else qdot


def _in_image(cam: Camera, P: FloatArray, margin_px: float) -> bool:
    if np.any(P[:, 2] <= 1e-9):
        return False
    xy = P[:, :2] / P[:, 2:3]
    return bool(np.all(cam.in_image(xy, margin_px=margin_px)))


def _objectives(
    opt: SimulationOptions,
    secondary: Callable[[TaskState, FloatArray, float], FloatArray | None] | None,
    objectives: Sequence[Objective],
) -> list[Objective]:
    out: list[Objective] = []
    if secondary is not None:
        out.append(CallableObjective(secondary))
    if opt.occlusion is not None:
        out.append(OcclusionAvoidance(opt.occlusion))
    out.extend(objectives)
    return out


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
        camera: Image size for the ``target_lost`` check (default :class:`Camera`).
        limits: Joint limits given to the law (default: the robot's, with ``options.rho``:
            position, velocity and acceleration limits).
        secondary: Optional ``f(state, q, t) -> (n,)`` extra joint command passed to the law.
        objectives: Further secondary objectives (:mod:`redservo.simulation.objectives`).
        sensor: Where the features come from (default :class:`~redservo.sensors.IdealSensor`).
        actuator: Joint actuator model (default: ideal, ``q + q̇ dt``).
        progress: Optional callback called with the iteration index.

    Returns:
        :class:`SimulationResult` with the outcome, the typed summary and the log.

    Raises:
        JointLimitError: ``q0`` is outside the limits.
    """
    opt = options or SimulationOptions()
    cam = camera or Camera()
    lim = limits or robot.limits(opt.rho)
    q = lim.check(q0, "q0").copy()
    n = robot.n
    model = robot
    if opt.eMc_model is not None:
        model = copy.copy(robot)
        model.eMc = opt.eMc_model
    qdot_sat = None
    if opt.qdot_max is not None:
        qdot_sat = np.broadcast_to(np.asarray(opt.qdot_max, dtype=float), (n,)).copy()
    sens = sensor or IdealSensor()
    objs = _objectives(opt, secondary, objectives)
    law.reset()
    sens.reset()
    if actuator is not None:
        actuator.reset(q)
    rng = np.random.default_rng(opt.seed)
    buf = LogBuffer(opt.max_iterations, n, task.k, task.m)
    outcome: Outcome = "max_iterations"
    limit_hit: dict[str, int] | None = None
    prev_e1: FloatArray | None = None
    prev_J1qdot: FloatArray | None = None
    qdot_prev = np.zeros(n)  # the robot starts at rest
    targets = sorted({term.target for term in task.terms})
    for it in range(opt.max_iterations):
        t = it * opt.dt
        q_meas = q if actuator is None else np.clip(actuator.encoder(q), lim.q_min, lim.q_max)
        bMc, J_true = robot.kinematics(q, check_limits=False)
        J = (
            J_true
            if model is robot and actuator is None
            else model.jacobian(q_meas, check_limits=False)
        )
        reading = sens.read(task, scene, bMc, t)
        if reading.s is None:
            outcome = _lost_outcome(reading)
            break
        s = reading.s
        if opt.noise_std > 0:
            s = s + rng.normal(0.0, opt.noise_std, task.k)
        try:
            state = task.evaluate_measured(s, reading.inv_depth, J, depth_scale=opt.depth_scale)
            if opt.check_image and not all(
                _in_image(cam, visible_points(scene, name, bMc, t), opt.image_margin_px)
                for name in targets
            ):
                raise GeometryError("an object left the image")
        except GeometryError:
            outcome = "target_lost"
            break
        sec, stop = _secondary(objs, ObjectiveContext(scene, bMc, J, q_meas, lim, state, t))
        if stop is not None:
            outcome = stop
            break
        de1_dt = None
        if opt.feedforward == "known":
            de1_dt = _known_feedforward(task, scene, bMc, t, opt.dt)
        elif opt.feedforward == "estimated" and prev_e1 is not None and prev_J1qdot is not None:
            de1_dt = (state.e1 - prev_e1) / opt.dt - prev_J1qdot
        res = law(
            J1=state.J1,
            e1=state.e1,
            q=q_meas,
            limits=lim,
            lam=opt.lam,
            dt=opt.dt,
            de1_dt=de1_dt,
            secondary=sec,
            qdot_prev=qdot_prev,
        )
        qdot = _saturate(res.qdot, qdot_sat)
        buf.append(t, q, qdot, J_true @ qdot, state, lim, res.diagnostics)
        err = float(np.linalg.norm(state.e1))
        if err < opt.tolerance and (opt.stop_at_convergence or it == opt.max_iterations - 1):
            outcome = "converged"
            break
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
        prev_e1, prev_J1qdot, qdot_prev = state.e1, state.J1 @ qdot, qdot
        # A step commanded exactly onto a limit lands on it (roundoff is not a crossing).
        q = np.clip(q_next, lim.q_min, lim.q_max)
        if progress is not None:
            progress(it)
    log = buf.to_log(robot.joint_names, task.names)
    summary = summarize(log, outcome, lim, limit_hit, dt=opt.dt, min_margin=opt.min_margin)
    return SimulationResult(outcome, summary, log)


def _secondary(
    objectives: Sequence[Objective], ctx: ObjectiveContext
) -> tuple[FloatArray | None, Outcome | None]:
    """Sum the objectives' commands; the first that ends the run wins."""
    total: FloatArray | None = None
    for obj in objectives:
        cmd, stop = obj(ctx)
        if stop is not None:
            return None, cast(Outcome, stop)
        if cmd is not None:
            total = cmd if total is None else total + cmd
    return total, None


def _known_feedforward(
    task: VisualTask, scene: Scene, bMc: FloatArray, t: float, dt: float
) -> FloatArray:
    """``∂e1/∂t`` from the target's known motion: central difference with the camera frozen."""
    h = 0.5 * dt
    s_p, _ = task.measure(scene, bMc, t + h)
    s_m, _ = task.measure(scene, bMc, max(t - h, 0.0))
    ds = task.error(s_p) - task.error(s_m)
    ds /= h + min(h, t)
    return ds if task.C is None else task.C @ ds
