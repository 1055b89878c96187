"""The record of a servo run: its rows, collected into a
:class:`~redservo.records.SimulationLog`, and the :class:`ServoResult` the loop returns.

The loop on a robot writes exactly the simulator's log (same arrays, same ``.npz`` and
``.csv`` files), so every plot and report made for simulations works on a real run.
Row i is loop iteration i from the first measurement on; ``camera_twist`` is computed
with the controller's model Jacobian (the true one is unknown on hardware).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, cast, get_args

import numpy as np

from redservo._validation import FloatArray
from redservo.hardware.clock import ClockFault
from redservo.limits import JointLimits
from redservo.records import LogBuffer, SimulationLog, summarize
from redservo.redundancy.base import Diagnostics
from redservo.task import TaskState

__all__ = [
    "SERVO_OUTCOMES",
    "LoopRecorder",
    "RunEnd",
    "ServoOutcome",
    "ServoResult",
    "servo_result",
]

ServoOutcome = Literal[
    "converged",
    "stopped",
    "stale_measurement",
    "clock_fault",
    "late",
    "not_following",
    "objective_stop",
    "error",
    "interrupted",
    "max_iterations",
]
SERVO_OUTCOMES: tuple[ServoOutcome, ...] = get_args(ServoOutcome)


@dataclass
class ServoResult:
    """How a servo run ended, its log (the simulator's format) and its timing."""

    outcome: ServoOutcome
    """``converged`` (``‖e1‖ < tolerance``), ``stopped``
    (:meth:`~redservo.hardware.ServoLoop.request_stop`), ``stale_measurement`` (watchdog),
    ``clock_fault`` (a time stamp broke the clock contract: :mod:`redservo.hardware.clock`),
    ``late`` (a command would have stayed in force longer than ``max_hold``, or too many
    consecutive overruns: :mod:`redservo.hardware.supervision`), ``not_following`` (the
    joints do not move as commanded, or the encoder is frozen), ``objective_stop`` (an objective ended the run, e.g. ``occluded``: the reason says which
    outcome), ``error`` (an exception, or a non-finite command), ``interrupted`` (Ctrl-C, or a
    ``BaseException`` such as ``SystemExit``, which is re-raised) or ``max_iterations``
    (``max_iterations`` or ``duration``)."""
    reason: str
    """One sentence saying what ended the run (with the iteration)."""
    log: SimulationLog
    """One row per iteration from the first measurement on."""
    summary: dict[str, Any]
    """The simulator's summary fields plus the loop's counters
    (see :meth:`~redservo.hardware.ServoLoop.run`)."""
    measured: np.ndarray
    """(N,) bool per log row: a fresh measurement was used (False: the command was held)."""
    cycle_time: FloatArray
    """(iterations,) compute time of each iteration (s), from the joint read to the send."""
    overruns: int = 0
    """Iterations that ended after their next tick."""
    error: BaseException | None = field(default=None, repr=False)
    """The exception that ended the run (outcome ``error`` or ``interrupted``), if any."""
    clock_fault: ClockFault | None = None
    """The offending time stamp (outcome ``clock_fault``): which source, which fault."""

    @property
    def iterations(self) -> int:
        """Number of iterations run."""
        return int(self.cycle_time.shape[0])

    def save(self, directory: str | Path, *, extra: dict[str, Any] | None = None) -> Path:
        """Write ``summary.json``, ``log.npz`` and ``log.csv`` into ``directory`` (as a simulation)."""
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        summary = {**self.summary, **(extra or {})}
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        self.log.save_npz(out / "log.npz")
        self.log.save_csv(out / "log.csv")
        return out


class LoopRecorder:
    """Rows of a servo run, one per iteration, in the simulator's :class:`LogBuffer` with no
    row cap (it grows as it fills: a loop on hardware may have no iteration cap), plus a flag
    per row saying whether a fresh measurement was used.

    Args:
        n: Number of joints.
        k: Number of stacked feature components.
        m: Task dimension.
    """

    def __init__(self, n: int, k: int, m: int) -> None:
        self.n, self.k, self.m = n, k, m
        self.buffer = LogBuffer(None, n, k, m)
        self.measured: list[bool] = []

    def __len__(self) -> int:
        return self.buffer.rows

    def append(
        self,
        *,
        t: float,
        q: FloatArray,
        qdot: FloatArray,
        twist: FloatArray,
        state: TaskState,
        limits: JointLimits,
        diagnostics: Diagnostics,
        measured: bool,
    ) -> None:
        """Add one row: time since start (s), joints, the command sent, the task state used,
        the law's diagnostics, and whether the measurement was fresh."""
        self.buffer.append(t, q, qdot, twist, state, limits, diagnostics)
        self.measured.append(measured)

    def to_log(self, joint_names: tuple[str, ...], feature_names: tuple[str, ...]) -> SimulationLog:
        """Return the rows as a :class:`SimulationLog`."""
        return self.buffer.to_log(joint_names, feature_names)


@dataclass
class RunEnd:
    """How a servo run ended (filled in by the loop, turned into a :class:`ServoResult`)."""

    outcome: ServoOutcome = "error"
    reason: str = ""
    error: BaseException | None = None
    clock_fault: ClockFault | None = None
    stop_error: BaseException | None = None
    """What ``robot.stop()`` raised, if anything."""


def servo_result(
    recorder: LoopRecorder,
    end: RunEnd,
    *,
    names: tuple[tuple[str, ...], tuple[str, ...]],
    limits: JointLimits,
    period: float,
    cycle: list[float],
    counters: dict[str, int],
) -> ServoResult:
    """Build the result of a run: its log, the simulator's summary plus the loop's fields.

    Args:
        recorder: The run's rows.
        end: How it ended.
        names: (joint names, feature names) of the log.
        limits: The limits the run was given (for the summary's margins and rates).
        period: Control period T (s).
        cycle: Compute time of each iteration (s).
        counters: The loop's counters (``overruns``, ``missing``, ``guarded``,
            ``acceleration_exceeded``), copied into the summary.
    """
    log = recorder.to_log(*names)
    measured = np.array(recorder.measured, dtype=bool)
    times = np.array(cycle, dtype=float)
    summary = summarize(log, cast(Any, end.outcome), limits, None, dt=period).to_dict()
    summary.update(
        reason=end.reason,
        loop_iterations=int(times.shape[0]),
        period=period,
        max_cycle_time=float(times.max()) if times.size else 0.0,
        held=int(np.count_nonzero(~measured)),
        clock_fault=end.clock_fault.to_dict() if end.clock_fault is not None else None,
        **counters,
    )
    return ServoResult(
        end.outcome,
        end.reason,
        log,
        summary,
        measured,
        times,
        counters.get("overruns", 0),
        end.error,
        end.clock_fault,
    )
