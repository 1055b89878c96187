"""A fixed-period servo loop that runs any control law on a real (or simulated) robot.

Each iteration, at times ``t0 + k T`` of a monotonic clock:

1. ``t, q = robot.read_joints()``;
2. ``m = source.measure(now)``: a *fresh* measurement (newer than the last one and at most
   ``watchdog_timeout`` old) gives ``e1 = C (s - s*)`` and ``J1 = C L(s, 1/Ẑ) J(q)`` with
   the controller's model robot, and the law computes ``q̇``; otherwise the loop holds the
   last command (``on_missing="hold"``) or asks for zero (``"zero"``);
3. the guard (:func:`~redservo.hardware.guard_command`) makes the command finite and within
   ``qdot_max``, ``qddot_max`` and the safe position range;
4. ``robot.send_velocity(q̇)``, then sleep until the next tick.

Guarantees (docs/real-robot.md): ``robot.stop()`` is called once at the end of *every* run,
whatever ended it; a command above ``limits.qdot_max`` or holding a NaN is never sent; with
no fresh measurement for more than ``watchdog_timeout`` seconds, or joint readings whose
time stamp ``t`` did not change for that long, the run stops (``stale_measurement``); an exception raised by the robot, the source, the task or the law
stops the robot and is re-raised with a note naming the stage and the iteration; Ctrl-C
stops the robot and returns ``interrupted``; a late iteration is counted as an overrun and
the next one starts at once (missed ticks are not caught up in a burst).

Units: seconds, metres, radians; ``λ`` in 1/s.
"""

from __future__ import annotations

import inspect
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal, cast

import numpy as np

from redservo._validation import FloatArray, as_vector
from redservo.errors import ConfigurationError, ShapeError
from redservo.hardware.guard import guard_command
from redservo.hardware.protocols import FeatureMeasurement, FeatureSource, RobotInterface
from redservo.hardware.recorder import LoopRecorder, ServoOutcome, ServoResult
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics, LawResult
from redservo.redundancy.flags import Flag
from redservo.robots.base import Robot
from redservo.simulation import summarize
from redservo.task import TaskState, VisualTask

__all__ = ["ServoLoop"]


@dataclass
class _Run:
    """Mutable state of one run (internal)."""

    t0: float
    next_tick: float
    prev: FloatArray
    recorder: LoopRecorder
    k: int = 0
    stage: str = "start"
    last: FeatureMeasurement | None = None
    joint_t: float | None = None
    joint_seen: float = 0.0
    state: TaskState | None = None
    diag: Diagnostics | None = None
    overruns: int = 0
    missing: int = 0
    guarded: int = 0
    cycle: list[float] = field(default_factory=list)


def _accepts_qdot_prev(law: Callable[..., LawResult]) -> bool:
    try:
        params = inspect.signature(law).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return False
    return "qdot_prev" in params or any(
        p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()
    )


def _law_replaced_non_finite(d: Diagnostics | None) -> bool:
    """True when a :class:`~redservo.Law` reported that it replaced a NaN/inf command."""
    return d is not None and d.has(Flag.NON_FINITE_REPLACED)


def _positive(value: float | None, name: str, unit: str) -> None:
    if value is not None and not (math.isfinite(value) and value > 0.0):
        raise ConfigurationError(f"{name} must be a positive number ({unit}), got {value!r}")


class ServoLoop:
    """Run a control law on a robot at a fixed period (see the module docstring).

    Args:
        robot_iface: The arm (:class:`~redservo.hardware.RobotInterface`).
        source: The features (:class:`~redservo.hardware.FeatureSource`).
        model_robot: The controller's kinematic model: ``J(q)`` for ``J1`` (its ``eMc`` is
            the hand-eye calibration).
        task: The visual task (``s*``, ``C``, depth option).
        law: A control law (:func:`redservo.make_law`) or any callable with its keywords;
            ``qdot_prev`` (the last command sent) is passed when the callable accepts it.
        limits: Joint limits; ``qdot_max``, ``qddot_max`` and the margin, when set, are
            enforced by the guard as well as by the law.
        period: Control period T (s), > 0; also the law's ``dt``.
        lam: Gain λ (1/s), passed to the law as is.
        watchdog_timeout: Stop when no fresh measurement arrived for this long (s), >= T, or
            when the time stamp of the joint readings did not change for this long.
        max_iterations: Stop after this many iterations (None: no limit).
        duration: Stop after this many seconds (None: no limit).
        tolerance: Convergence threshold on ``‖e1‖`` (task units).
        stop_at_convergence: End the run with ``converged`` when ``‖e1‖ < tolerance``.
        on_missing: Without a fresh measurement, ``"hold"`` re-sends the last command and
            ``"zero"`` asks for zero velocity (both through the guard, so the change obeys
            ``qddot_max``).
        clock: Monotonic clock (s); inject a :class:`~redservo.hardware.VirtualClock` in tests.
        sleep: Sleep function (s); the virtual clock's ``sleep`` in tests.

    Raises:
        ConfigurationError: a period, gain, timeout or limit is not positive, or
            ``on_missing`` is not ``"hold"`` or ``"zero"``.
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
        watchdog_timeout: float = 0.5,
        max_iterations: int | None = None,
        duration: float | None = None,
        tolerance: float = 1e-3,
        stop_at_convergence: bool = True,
        on_missing: Literal["hold", "zero"] = "hold",
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        _positive(period, "period", "s")
        _positive(watchdog_timeout, "watchdog_timeout", "s")
        _positive(duration, "duration", "s")
        _positive(tolerance, "tolerance", "task units")
        if isinstance(lam, int | float):
            _positive(float(lam), "lam", "1/s")
        if watchdog_timeout < period:
            raise ConfigurationError(
                f"watchdog_timeout ({watchdog_timeout!r} s) must be at least the period "
                f"({period!r} s)"
            )
        if max_iterations is not None and max_iterations < 1:
            raise ConfigurationError(f"max_iterations must be >= 1, got {max_iterations!r}")
        if on_missing not in ("hold", "zero"):
            raise ConfigurationError(f"on_missing must be 'hold' or 'zero', got {on_missing!r}")
        if limits.n != model_robot.n:
            raise ShapeError(f"limits has {limits.n} joints but model_robot has {model_robot.n}")
        self.robot = robot_iface
        self.source = source
        self.model_robot = model_robot
        self.task = task
        self.law = law
        self.limits = limits
        self.period = float(period)
        self.lam = lam
        self.watchdog_timeout = float(watchdog_timeout)
        self.max_iterations = max_iterations
        self.duration = duration
        self.tolerance = float(tolerance)
        self.stop_at_convergence = stop_at_convergence
        self.on_missing = on_missing
        self.clock = clock
        self.sleep = sleep
        self.passes_qdot_prev = _accepts_qdot_prev(law)
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
                ``result.error``. The result is in :attr:`last_result` in both cases.

        Returns:
            :class:`ServoResult`. Its ``summary`` has the simulator's fields plus
            ``reason``, ``overruns``, ``max_cycle_time`` (s), ``held`` (iterations without a
            fresh measurement), ``missing`` (``measure`` returned None) and ``guarded``
            (iterations whose command the guard changed).
        """
        self._stop_request.clear()
        t0 = self.clock()
        n = self.model_robot.n
        run = _Run(t0, t0, np.zeros(n), LoopRecorder(n, self.task.k, self.task.m))
        outcome: ServoOutcome = "error"
        reason, error, stop_error = "", None, None
        try:
            try:
                outcome, reason = self._loop(run)
            except KeyboardInterrupt:
                outcome, reason = "interrupted", f"KeyboardInterrupt at iteration {run.k}"
            except Exception as exc:
                outcome, error = "error", exc
                reason = (
                    f"{type(exc).__name__} in {run.stage} at iteration {run.k} "
                    f"(t = {self.clock() - t0:.3f} s): {exc}"
                )
        finally:
            try:
                self.robot.stop()
            except Exception as exc:
                stop_error = exc
        if stop_error is not None and error is None:
            outcome, error = "error", stop_error
            reason = f"robot.stop() raised {type(stop_error).__name__}: {stop_error} ({reason})"
        result = self._result(run, outcome, reason, error)
        self.last_result = result
        if error is not None:
            error.add_note(
                f"redservo ServoLoop: {reason.split(': ')[0]}; robot.stop() was called"
                + (f" and raised {stop_error!r}" if stop_error is not None else "")
            )
            if raise_errors:
                raise error
        return result

    def _loop(self, run: _Run) -> tuple[ServoOutcome, str]:
        while True:
            if self._stop_request.is_set():
                return "stopped", f"request_stop() at iteration {run.k}"
            if self.max_iterations is not None and run.k >= self.max_iterations:
                return "max_iterations", f"max_iterations = {self.max_iterations} reached"
            start = self.clock()
            if self.duration is not None and start - run.t0 >= self.duration - 1e-9:
                return "max_iterations", f"duration {self.duration} s reached at iteration {run.k}"
            done = self._iteration(run)
            end = self.clock()
            run.cycle.append(end - start)
            if done is not None:
                return done
            run.k += 1
            run.next_tick += self.period
            if end > run.next_tick:
                run.overruns += 1
                run.next_tick = end  # start at once; the schedule restarts from here
            else:
                run.stage = "sleep"
                self.sleep(run.next_tick - end)

    def _fresh(self, run: _Run, meas: FeatureMeasurement | None, now: float) -> bool:
        """Validate ``meas`` and keep it if it is new and young enough."""
        if meas is None:
            run.missing += 1
            return False
        if run.last is not None and meas.t_measured <= run.last.t_measured:
            return False  # the same image again
        if now - meas.t_measured > self.watchdog_timeout:
            return False
        as_vector(meas.s, "s from source.measure()", self.task.k)
        if len(meas.inv_depth) != len(self.task.terms):
            raise ShapeError(
                f"source.measure() gave {len(meas.inv_depth)} inverse-depth entries; the task "
                f"has {len(self.task.terms)} terms"
            )
        run.last = meas
        return True

    def _iteration(self, run: _Run) -> tuple[ServoOutcome, str] | None:
        """One iteration; return (outcome, reason) to end the run, None to continue."""
        run.stage = "robot.read_joints"
        t_read, q_read = self.robot.read_joints()
        q = as_vector(q_read, "q from robot.read_joints()", self.model_robot.n)
        now = self.clock()
        if run.joint_t is None or t_read != run.joint_t:
            run.joint_t, run.joint_seen = t_read, now
        elif now - run.joint_seen > self.watchdog_timeout:
            return "stale_measurement", (
                f"the joint readings kept the time stamp {t_read!r} for "
                f"{now - run.joint_seen:.3f} s (watchdog_timeout {self.watchdog_timeout} s) "
                f"at iteration {run.k}"
            )
        run.stage = "source.measure"
        fresh = self._fresh(run, self.source.measure(now), now)
        age = now - (run.last.t_measured if run.last is not None else run.t0)
        if age > self.watchdog_timeout:
            return "stale_measurement", (
                f"no fresh measurement for {age:.3f} s (watchdog_timeout "
                f"{self.watchdog_timeout} s) at iteration {run.k}"
            )
        run.stage = "model_robot.jacobian"
        J = self.model_robot.jacobian(q, check_limits=False)
        if fresh:
            assert run.last is not None
            run.stage = "task"
            run.state = self.task.evaluate_measured(
                np.asarray(run.last.s, dtype=float), run.last.inv_depth, J
            )
            run.stage = "law"
            res = self.law(**self._law_kwargs(run, q))
            qdot, run.diag = res.qdot, res.diagnostics
        elif run.state is None:  # nothing measured yet: keep still
            run.stage = "robot.send_velocity"
            self.robot.send_velocity(np.zeros_like(q))
            return None
        else:
            qdot = run.prev if self.on_missing == "hold" else np.zeros_like(q)
        run.stage = "guard"
        cmd, report = guard_command(
            np.asarray(qdot, dtype=float),
            q=q,
            qdot_prev=run.prev,
            limits=self.limits,
            period=self.period,
        )
        run.guarded += int(report.changed)
        assert run.state is not None and run.diag is not None
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
        self.robot.send_velocity(cmd)
        run.prev = cmd
        return None

    def _law_kwargs(self, run: _Run, q: FloatArray) -> dict[str, Any]:
        assert run.state is not None
        kw: dict[str, Any] = {
            "J1": run.state.J1,
            "e1": run.state.e1,
            "q": q,
            "limits": self.limits,
            "lam": self.lam,
            "dt": self.period,
        }
        if self.passes_qdot_prev:
            kw["qdot_prev"] = run.prev
        return kw

    def _result(
        self, run: _Run, outcome: ServoOutcome, reason: str, error: BaseException | None
    ) -> ServoResult:
        log = run.recorder.to_log(self.model_robot.joint_names, self.task.names)
        measured = np.array(run.recorder.measured, dtype=bool)
        cycle = np.array(run.cycle, dtype=float)
        summary = summarize(log, cast(Any, outcome), self.limits, None, dt=self.period).to_dict()
        summary.update(
            reason=reason,
            loop_iterations=int(cycle.shape[0]),
            period=self.period,
            overruns=run.overruns,
            max_cycle_time=float(cycle.max()) if cycle.size else 0.0,
            held=int(np.count_nonzero(~measured)),
            missing=run.missing,
            guarded=run.guarded,
        )
        return ServoResult(outcome, reason, log, summary, measured, cycle, run.overruns, error)
