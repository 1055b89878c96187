"""A fixed-period servo loop that runs any control law on a real (or simulated) robot.

Each iteration, at times ``t0 + k T`` of the loop's monotonic ``clock``:

1. ``t, q = robot.read_joints()``;
2. ``m = source.measure(now)``: a *fresh* measurement (newer than the last one and at most
   ``watchdog_timeout`` old) goes to the loop's :class:`~redservo.Controller`
   (:attr:`ServoLoop.controller`, the same object the simulator drives): ``e1 = C (s - s*)``
   and ``J1 = C L(s, 1/Ẑ) J(q)`` with the controller's model robot, the ``objectives``
   summed into the law's ``secondary``, the ``"estimated"`` feed-forward from the previous
   measurement, and the law computes ``q̇``; otherwise the loop holds the last command
   (``on_missing="hold"``) or asks for zero (``"zero"``). An objective that ends the run
   (e.g. ``occluded``) stops the arm with the outcome ``objective_stop``;
3. the guard (:func:`~redservo.hardware.guard_command`) makes the command finite and within
   ``qdot_max``, ``qddot_max`` and the safe position range over the longest time it may stay
   in force, ``supervision.max_hold`` (:mod:`redservo.hardware.supervision`);
4. ``robot.send_velocity(q̇)``, then sleep until the next tick.

**Clock contract** (:mod:`redservo.hardware.clock`): the stamps ``t`` of the joint readings
and ``t_measured`` of the measurements are on the loop's ``clock`` (monotonic seconds). A
stamp that is not finite, ahead of the clock by more than ``clock_tolerance``, or earlier
than the stream's newest one ends the run with ``clock_fault`` (``result.clock_fault``
says which source and which fault). Freshness is judged on the stamp *and* on the arrival,
so a frozen source stops the arm at the first tick more than ``watchdog_timeout`` after its
last fresh reading, whatever it stamps. Before the first fresh joint reading and the first
fresh measurement the loop commands zero.

Guarantees (docs/real-robot.md): ``robot.stop()`` is called once at the end of *every* run,
whatever ended it; a command above ``limits.qdot_max`` or holding a NaN is never sent; with
no fresh measurement, or no fresh joint reading, for more than ``watchdog_timeout`` seconds
the run stops (``stale_measurement``) without sending another command; an exception raised
by the robot, the source, the task, an objective or the law stops the robot and is re-raised
with a note naming the stage and the iteration (``SystemExit`` and other ``BaseException``
too, always re-raised); the partial log is kept in :attr:`ServoLoop.last_result` in every
case; Ctrl-C stops the robot and returns ``interrupted``; a late iteration is counted as an
overrun and the next one starts at once (missed ticks are not caught up in a burst); a
command is never left in force longer than ``max_hold`` while the loop runs, and
``max_overruns`` overruns in a row end the run (``late``); joints that do not move as
commanded, or a frozen encoder, end it (``not_following``).

Units: seconds, metres, radians; ``λ`` in 1/s.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any, Literal

import numpy as np

from redservo._validation import FloatArray
from redservo.control import Controller, ControlStep, ImageMotionLimit, Measurement, Objective
from redservo.control.avoidance import Collision, shield_command
from redservo.control.guard import guard_command
from redservo.errors import ShapeError
from redservo.hardware.clock import StampWatch
from redservo.hardware.inputs import EndRun, RunState, measure, read_joints
from redservo.hardware.protocols import FeatureSource, RobotInterface
from redservo.hardware.recorder import (
    LoopRecorder,
    RunEnd,
    ServoOutcome,
    ServoResult,
    servo_result,
)
from redservo.hardware.settings import LoopSettings, check_servo_control, check_timing
from redservo.hardware.supervision import FollowWatch, Supervision
from redservo.kernels.blas import one_blas_thread
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics, LawResult
from redservo.redundancy.flags import Flag
from redservo.robots.base import Robot
from redservo.sensors.flags import with_no_pose
from redservo.task import VisualTask

__all__ = ["ServoLoop"]


def _law_replaced_non_finite(d: Diagnostics | None) -> bool:
    """True when a :class:`~redservo.Law` reported that it replaced a NaN/inf command."""
    return d is not None and d.has(Flag.NON_FINITE_REPLACED)


class ServoLoop(LoopSettings):
    """Run a control law on a robot at a fixed period (see the module docstring).

    Args:
        robot_iface: The arm (:class:`~redservo.hardware.RobotInterface`).
        source: The features (:class:`~redservo.hardware.FeatureSource`).
        model_robot: The controller's kinematic model: ``J(q)`` for ``J1`` (its ``eMc`` is
            the hand-eye calibration).
        task: The visual task (``s*``, ``C``, depth option).
        law: A control law (:func:`redservo.make_law`) or any callable with its keywords;
            ``qdot_prev`` (the last command sent), ``secondary`` and ``de1_dt`` are passed
            when the callable accepts them.
        limits: Joint limits; ``qdot_max``, ``qddot_max`` and the margin, when set, are
            enforced by the guard as well as by the law.
        period: Control period T (s), > 0; also the law's ``dt``.
        lam: Gain λ (1/s) > 0, or an :class:`~redservo.AdaptiveGain`, passed to the law.
        objectives: Secondary objectives (:mod:`redservo.control.objectives`), summed into
            the law's ``secondary``. They get no scene and no true camera pose (``ctx.scene``
            and ``ctx.bMc`` are None): an objective that needs them is refused here unless
            given its own (``OcclusionAvoidance(occlusion, scene=...)``).
        feedforward: ``"none"`` or ``"estimated"``: ``∂e1/∂t`` of a moving target from the
            loop's own successive measurements, ``(e1_k − e1_{k−1})/h − J1_{k−1} q̇``, with
            ``h`` the time between the two steps (the measurements brought to the present by
            the Controller's latency compensation; between their stamps when it is off) and
            ``q̇`` the command sent since (:mod:`redservo.control.feedforward`). ``"known"``
            needs the scene's motion, which only the simulator has.
        watchdog_timeout: Stop when no fresh measurement, or no fresh joint reading, arrived
            for this long (s), >= T (:mod:`redservo.hardware.clock`).
        clock_tolerance: How far (s) a time stamp may be ahead of the loop's clock before it
            is a ``clock_fault``, >= 0 and < ``watchdog_timeout``. The default, 5 ms, covers
            the error of converting a device's stamps to the loop's clock; a stamp on
            another clock (``time.time()``) is off by far more.
        max_iterations: Stop after this many iterations (None: no limit).
        duration: Stop after this many seconds (None: no limit).
        tolerance: Convergence threshold on ``‖e1‖`` (task units).
        stop_at_convergence: End the run with ``converged`` when ``‖e1‖ < tolerance``.
        on_missing: Without a fresh measurement, ``"hold"`` re-sends the last command and
            ``"zero"`` asks for zero velocity (both through the guard, so the change obeys
            ``qddot_max``).
        clock: Monotonic clock (s), the clock of every time stamp; inject a
            :class:`~redservo.hardware.VirtualClock` in tests.
        sleep: Sleep function (s); the virtual clock's ``sleep`` in tests.
        supervision: The late-loop and not-following thresholds
            (:class:`~redservo.hardware.Supervision`; default ``Supervision()``: a command
            held at most ``watchdog_timeout``, 5 consecutive overruns, a 1 s following
            window, 5 identical readings for a frozen encoder).
        image_motion: The camera-motion limit (:class:`~redservo.control.ImageMotionLimit`):
            the Controller scales each command so that no image point moves further between
            two of the camera's frames than the tracker follows. None: none.
        collision: The distance shield's set-up (:class:`~redservo.control.avoidance.Collision`,
            the obstacles' poses known): the controller's shield, then again after the guard
            (over ``max_hold``), so the guard's acceleration step never undoes it. Its
            repulsion is the objective ``CollisionAvoidance(collision)``.

    Raises:
        ConfigurationError: a period, gain, timeout, tolerance, limit or supervision
            threshold is out of range,
            ``on_missing`` is not ``"hold"`` or ``"zero"``, ``feedforward`` is not ``"none"``
            or ``"estimated"``, an objective needs the scene, or the law cannot take what the
            objectives or the feed-forward need (the error's ``argument`` names which).
        ShapeError: ``limits`` and ``model_robot`` have different numbers of joints.
    """

    def __init__(
        self,
        robot_iface: RobotInterface,
        source: FeatureSource,
        model_robot: Robot,
        task: VisualTask,
        law: Callable[..., LawResult],
        limits: JointLimits,
        *,
        period: float,
        lam: Any,
        objectives: Sequence[Objective] = (),
        feedforward: Literal["none", "estimated"] = "none",
        watchdog_timeout: float = 0.5,
        clock_tolerance: float = 0.005,
        max_iterations: int | None = None,
        duration: float | None = None,
        tolerance: float = 1e-3,
        stop_at_convergence: bool = True,
        on_missing: Literal["hold", "zero"] = "hold",
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        supervision: Supervision | None = None,
        image_motion: ImageMotionLimit | None = None,
        collision: Collision | None = None,
    ) -> None:
        check_timing(period, watchdog_timeout, clock_tolerance, duration, tolerance, lam)
        self._set_ending(max_iterations, duration, tolerance, stop_at_convergence, on_missing)
        if limits.n != model_robot.n:
            raise ShapeError(f"limits has {limits.n} joints but model_robot has {model_robot.n}")
        check_servo_control(objectives, feedforward)
        self.controller = Controller(
            model_robot,
            task,
            law,
            limits,
            lam=lam,
            dt=period,
            objectives=objectives,
            feedforward=feedforward,
            image_motion=image_motion,
            collision=collision,
        )
        """The control core (task, objectives, feed-forward, law) the loop drives."""
        self.robot = robot_iface
        self.source = source
        self.model_robot = model_robot
        self.task = task
        self.law = law
        self.limits = limits
        self.lam = lam
        self._set_timing(period, watchdog_timeout, clock_tolerance, clock, sleep, supervision)
        self.passes_qdot_prev = "qdot_prev" in self.controller.accepts
        self.last_result: ServoResult | None = None
        self._stop_request = threading.Event()

    def request_stop(self) -> None:
        """Ask the running loop to stop at its next iteration (thread-safe); outcome ``stopped``."""
        self._stop_request.set()

    # -- the run -------------------------------------------------------------------------------

    def run(self, *, raise_errors: bool = True) -> ServoResult:
        """Run until convergence, a stop condition, an error or Ctrl-C; always stop the robot.

        Args:
            raise_errors: Re-raise an exception from the robot, source, task or law (after
                stopping the robot, with a note naming the stage and the iteration). When
                False, return the result with outcome ``error`` and the exception in
                ``result.error``. A ``BaseException`` other than ``KeyboardInterrupt``
                (``SystemExit``, ``GeneratorExit``, ...) is always re-raised (outcome
                ``interrupted``). The result, partial log included, is in
                :attr:`last_result` in every case.

        Returns:
            :class:`ServoResult`. Its ``summary`` has the simulator's fields plus
            ``reason``, ``overruns``, ``max_cycle_time`` (s), ``held`` (iterations without a
            fresh measurement), ``missing`` (``measure`` returned None), ``guarded``
            (iterations whose command the guard changed), ``acceleration_exceeded``
            (iterations whose command changed by more than ``qddot_max·T``: the guard's
            position clip) and ``clock_fault`` (the offending stamp, or None).
        """
        self._stop_request.clear()
        bind = getattr(self.controller.law, "bind_period", None)  # predictive's default budget
        if callable(bind):  # a share of the period, on the loop's clock
            bind(self.period, self.clock)
        warm_up = getattr(self.controller.law, "warm_up", None)  # e.g. predictive's first call
        if callable(warm_up):  # one-time costs paid before the first period, not inside it
            warm_up(self.controller.limits, self.task.m, self.period)
        run = self._new_run()
        end = RunEnd()
        try:
            with one_blas_thread():  # the compiled steps: one BLAS thread (kernels/blas.py)
                end.outcome, end.reason = self._loop(run)
        except EndRun as stop:
            end.outcome, end.reason, end.clock_fault = stop.outcome, stop.reason, stop.fault
        except KeyboardInterrupt:
            end.outcome, end.reason = "interrupted", f"KeyboardInterrupt at iteration {run.k}"
        except BaseException as exc:  # SystemExit included: logged here, re-raised below
            end.outcome = "error" if isinstance(exc, Exception) else "interrupted"
            end.error = exc
            end.reason = (
                f"{type(exc).__name__} in {run.stage} at iteration {run.k} "
                f"(t = {self.clock() - run.t0:.3f} s): {exc}"
            )
        finally:
            self._stop_robot(end)
            self.last_result = servo_result(
                run.recorder,
                end,
                names=(self.model_robot.joint_names, self.task.names),
                limits=self.limits,
                period=self.period,
                cycle=run.cycle,
                counters=run.counters,
            )
        if end.error is not None:
            end.error.add_note(
                f"redservo ServoLoop: {end.reason.split(': ')[0]}; robot.stop() was called"
                + (f" and raised {end.stop_error!r}" if end.stop_error is not None else "")
            )
            if raise_errors or not isinstance(end.error, Exception):
                raise end.error
        return self.last_result

    def _new_run(self) -> RunState:
        self.controller.reset()
        t0 = self.clock()
        n = self.model_robot.n
        watch = partial(
            StampWatch, tolerance=self.clock_tolerance, timeout=self.watchdog_timeout, t0=t0
        )
        recorder = LoopRecorder(n, self.task.k, self.task.m)
        run = RunState(t0, t0, np.zeros(n), recorder, watch("joints"), watch("measurement"))
        run.follow = FollowWatch(self.supervision)
        return run

    def _stop_robot(self, end: RunEnd) -> None:
        """Call ``robot.stop()`` once; what it raises ends the run as an error of its own."""
        try:
            self.robot.stop()
        except BaseException as exc:
            end.stop_error = exc
            if end.error is None:
                end.error = exc
                end.outcome = "error" if isinstance(exc, Exception) else "interrupted"
                end.reason = f"robot.stop() raised {type(exc).__name__}: {exc} ({end.reason})"

    def _loop(self, run: RunState) -> tuple[ServoOutcome, str]:
        while True:
            if self._stop_request.is_set():
                return "stopped", f"request_stop() at iteration {run.k}"
            if self.max_iterations is not None and run.k >= self.max_iterations:
                return "max_iterations", f"max_iterations = {self.max_iterations} reached"
            start = self.clock()
            if self.duration is not None and start - run.t0 >= self.duration - 1e-9:
                return "max_iterations", f"duration {self.duration} s reached at iteration {run.k}"
            try:
                done = self._iteration(run)
            finally:
                run.cycle.append(self.clock() - start)
            if done is not None:
                return done
            end = start + run.cycle[-1]
            late = self._late(run, end, "after")
            if late is not None:
                return late
            run.k += 1
            run.next_tick += self.period
            if end > run.next_tick:
                run.counters["overruns"] += 1
                run.late += 1
                if run.late >= self.supervision.max_overruns:
                    return "late", (
                        f"{run.late} consecutive overruns (max_overruns "
                        f"{self.supervision.max_overruns}) at iteration {run.k - 1}"
                    )
                run.next_tick = end  # start at once; the schedule restarts from here
            else:
                run.late = 0
                run.stage = "sleep"
                self.sleep(run.next_tick - end)

    def _iteration(self, run: RunState) -> tuple[ServoOutcome, str] | None:
        """One iteration; return (outcome, reason) to end the run, None to continue."""
        q, now = read_joints(run, self.robot, self.clock, self.model_robot.n)
        if run.joints.fresh_arrival == now and run.follow is not None:
            fault = run.follow.observe(q, now)
            if fault is not None:
                return "not_following", f"{fault} at iteration {run.k}"
        fresh = measure(run, self.source, self.clock, self.task, now)
        run.stage = "model_robot.jacobian"
        J = self.model_robot.jacobian(q, check_limits=False)
        if fresh and run.joints.ever_fresh:
            step = self._control(run, q, J, now)
            if step.stop is not None:
                return (
                    "objective_stop",
                    f"an objective ended the run ({step.stop}) at iteration {run.k}",
                )
            qdot, run.diag = step.qdot, step.diagnostics
            miss = getattr(run.last, "no_pose", None)  # a source of the image sensor's PnP
            if run.diag is not None:
                run.diag = with_no_pose(run.diag, miss)
        elif run.state is None:  # nothing measured, or no fresh joint reading, yet: keep still
            self._deliver(run, np.zeros_like(q))
            return None
        else:
            qdot = run.prev if self.on_missing == "hold" else np.zeros_like(q)
        return self._send(run, qdot, q, J, now, fresh)

    def _send(
        self, run: RunState, qdot: FloatArray, q: FloatArray, J: FloatArray, now: float, fresh: bool
    ) -> tuple[ServoOutcome, str] | None:
        """Guard, log and send the command (or end the run: non-finite, converged)."""
        run.stage = "guard"
        late = self._late(run, self.clock(), "before")
        if late is not None:
            return late
        # Where the command in force has taken the joints since the read (the law's time).
        q_send = q + run.prev * max(self.clock() - now, 0.0)
        cmd, report = guard_command(
            np.asarray(qdot, dtype=float),
            q=q_send,
            qdot_prev=run.prev,
            limits=self.limits,
            period=self.period,
            hold=self.supervision.max_hold,
        )
        run.counters["guarded"] += int(report.changed)
        run.counters["acceleration_exceeded"] += int(bool(report.acceleration_exceeded))
        assert run.state is not None and run.diag is not None
        hold, qddot_max = self.supervision.max_hold or self.period, self.limits.qddot_max
        coll, t = self.controller.collision, now - run.t0
        cmd, run.diag = shield_command(
            coll, self.model_robot, cmd, run.diag, q_send, t, hold, run.prev, qddot_max
        )
        run.recorder.append(
            t=now - run.t0,
            q=q,
            qdot=cmd,
            twist=J @ cmd,
            state=run.state,
            limits=self.limits,
            diagnostics=run.diag,
            measured=fresh,
        )
        run.stage = "robot.send_velocity"
        if report.non_finite or (fresh and _law_replaced_non_finite(run.diag)):
            self.robot.send_velocity(np.zeros_like(cmd))
            return "error", f"the law returned a non-finite command at iteration {run.k}"
        if fresh and self.stop_at_convergence and np.linalg.norm(run.state.e1) < self.tolerance:
            return "converged", f"‖e1‖ < {self.tolerance:g} at iteration {run.k}"
        run.prev = cmd
        self._deliver(run, cmd)
        return None

    def _deliver(self, run: RunState, cmd: FloatArray) -> None:
        """Send ``cmd`` (n,) and note when: it is in force from now on."""
        run.stage = "robot.send_velocity"
        run.sent_at = self.clock()
        if run.follow is not None:
            run.follow.commanded(cmd, run.sent_at)
        self.robot.send_velocity(cmd)

    def _late(self, run: RunState, t: float, when: str) -> tuple[ServoOutcome, str] | None:
        """End the run when the command in force at loop time ``t`` (s) has been so for more
        than ``max_hold`` (:mod:`redservo.hardware.supervision`)."""
        hold = self.supervision.max_hold
        assert hold is not None
        if run.sent_at is None or t - run.sent_at <= hold + 1e-9:
            return None
        return "late", (
            f"the command sent {t - run.sent_at:.3f} s ago was still in force {when} iteration "
            f"{run.k} (max_hold {hold:g} s): the loop ran late"
        )

    def _control(self, run: RunState, q: FloatArray, J: FloatArray, now: float) -> ControlStep:
        """The controller's step on the fresh measurement ``run.last``: at the present time
        ``now`` (loop clock, s) with the measurement stamped at its image's time, which the
        controller brings to the present with the commands sent since (its
        ``compensate_latency``, :mod:`redservo.control.latency`); at the stamp's time without
        it."""
        assert run.last is not None
        ctrl = self.controller
        seen = float(run.last.t_measured) - run.t0
        try:
            if ctrl.compensate_latency:
                meas = Measurement(run.last.s, tuple(run.last.inv_depth), seen)
                t = max(now - run.t0, seen)  # a stamp ahead within clock_tolerance: no age
                step = ctrl.step(q, meas, t, qdot_prev=run.prev, J=J)
            else:
                step = ctrl.step(q, run.last, seen, qdot_prev=run.prev, J=J)
            run.state = step.state
            return step
        finally:
            run.stage = ctrl.stage  # named in the note of an exception
