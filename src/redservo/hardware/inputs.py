"""The servo loop's inputs, read and checked each iteration: the joint readings and the
feature measurement, judged against the clock contract (:mod:`redservo.hardware.clock`),
and the mutable state of one run that they update.

A broken stamp ends the run with ``clock_fault``, a stream without a fresh reading for more
than ``watchdog_timeout`` with ``stale_measurement``: both by raising :class:`EndRun`, which
the loop turns into its result (after stopping the robot).

Units: seconds, metres, radians.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from redservo._validation import FloatArray, as_vector
from redservo.errors import ShapeError
from redservo.hardware.clock import ClockFault, StampWatch
from redservo.hardware.protocols import FeatureMeasurement, FeatureSource, RobotInterface
from redservo.hardware.recorder import LoopRecorder, ServoOutcome
from redservo.hardware.supervision import FollowWatch
from redservo.redundancy.base import Diagnostics
from redservo.task import TaskState, VisualTask

__all__ = ["COUNTERS", "EndRun", "RunState", "measure", "read_joints"]

COUNTERS: tuple[str, ...] = ("overruns", "missing", "guarded", "acceleration_exceeded")
"""The loop's counters, copied into the run summary."""


@dataclass
class RunState:
    """Mutable state of one run of the servo loop."""

    t0: float
    """Loop time of the start (s)."""
    next_tick: float
    prev: FloatArray
    """The command sent last (n,), zeros at the start."""
    recorder: LoopRecorder
    joints: StampWatch
    feed: StampWatch
    """The measurements' stamps."""
    k: int = 0
    """Current iteration (0-based)."""
    stage: str = "start"
    """What the loop is doing (named in the note of an exception)."""
    last: FeatureMeasurement | None = None
    """The last fresh measurement."""
    state: TaskState | None = None
    diag: Diagnostics | None = None
    counters: dict[str, int] = field(default_factory=lambda: dict.fromkeys(COUNTERS, 0))
    cycle: list[float] = field(default_factory=list)
    """Compute time of each iteration (s)."""
    follow: FollowWatch | None = None
    """The following and frozen-encoder checks."""
    sent_at: float | None = None
    """Loop time of the last command sent (s), None before the first."""
    late: int = 0
    """Consecutive overruns."""


class EndRun(Exception):
    """Raised inside an iteration to end the run with ``outcome`` (caught by the loop)."""

    def __init__(self, outcome: ServoOutcome, reason: str, fault: ClockFault | None = None) -> None:
        super().__init__(reason)
        self.outcome, self.reason, self.fault = outcome, reason, fault


def _check(run: RunState, watch: StampWatch, stamp: object, arrival: float) -> bool:
    """Judge ``stamp`` (arrived at loop time ``arrival``): fresh or not; a fault ends the run."""
    verdict = watch.observe(stamp, arrival)
    if isinstance(verdict, ClockFault):
        raise EndRun(
            "clock_fault",
            f"clock fault ({verdict.kind}) at iteration {run.k}: {verdict.message()}",
            verdict,
        )
    return verdict


def _watchdog(run: RunState, watch: StampWatch, now: float) -> None:
    if watch.stale(now):
        raise EndRun(
            "stale_measurement", f"watchdog: {watch.describe_stale(now)} at iteration {run.k}"
        )


def read_joints(
    run: RunState, robot: RobotInterface, clock: Callable[[], float], n: int
) -> tuple[FloatArray, float]:
    """Read the joints and return ``(q, now)``: the (n,) positions and the loop time (s)
    just after the read.

    Raises:
        EndRun: the stamp broke the clock contract, or no fresh joint reading arrived for
            more than ``watchdog_timeout``.
        ShapeError: ``q`` has the wrong length or holds NaN or inf.
    """
    run.stage = "robot.read_joints"
    t_read, q_read = robot.read_joints()
    now = clock()
    _check(run, run.joints, t_read, now)
    q = as_vector(q_read, "q from robot.read_joints()", n)
    _watchdog(run, run.joints, now)
    return q, now


def measure(
    run: RunState,
    source: FeatureSource,
    clock: Callable[[], float],
    task: VisualTask,
    now: float,
) -> bool:
    """Take the measurement at loop time ``now`` (s); keep it in ``run.last`` and return True
    when it is fresh.

    Raises:
        EndRun: the stamp broke the clock contract, or no fresh measurement arrived for
            more than ``watchdog_timeout``.
        ShapeError: a fresh measurement does not fit the task.
    """
    run.stage = "source.measure"
    meas = source.measure(now)
    fresh = False
    if meas is None:
        run.counters["missing"] += 1
    elif _check(run, run.feed, meas.t_measured, clock()):
        as_vector(meas.s, "s from source.measure()", task.k)
        if len(meas.inv_depth) != len(task.terms):
            raise ShapeError(
                f"source.measure() gave {len(meas.inv_depth)} inverse-depth entries; the "
                f"task has {len(task.terms)} terms"
            )
        run.last, fresh = meas, True
    _watchdog(run, run.feed, now)
    return fresh
