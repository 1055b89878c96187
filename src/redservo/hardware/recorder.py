"""The record of a servo run: its rows, collected into a
:class:`~redservo.simulation.SimulationLog`, and the :class:`ServoResult` the loop returns.

The loop on a robot writes exactly the simulator's log (same arrays, same ``.npz`` and
``.csv`` files), so every plot and report made for simulations works on a real run.
Row i is loop iteration i from the first measurement on; ``camera_twist`` is computed
with the controller's model Jacobian (the true one is unknown on hardware).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from redservo._validation import FloatArray
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics
from redservo.simulation import LogBuffer, SimulationLog
from redservo.task import TaskState

__all__ = ["SERVO_OUTCOMES", "LoopRecorder", "ServoOutcome", "ServoResult"]

ServoOutcome = Literal[
    "converged", "stopped", "stale_measurement", "error", "interrupted", "max_iterations"
]
SERVO_OUTCOMES: tuple[ServoOutcome, ...] = (
    "converged",
    "stopped",
    "stale_measurement",
    "error",
    "interrupted",
    "max_iterations",
)


@dataclass
class ServoResult:
    """How a servo run ended, its log (the simulator's format) and its timing."""

    outcome: ServoOutcome
    """``converged`` (``‖e1‖ < tolerance``), ``stopped``
    (:meth:`~redservo.hardware.ServoLoop.request_stop`), ``stale_measurement`` (watchdog), ``error`` (an exception, or a non-finite command),
    ``interrupted`` (Ctrl-C) or ``max_iterations`` (``max_iterations`` or ``duration``)."""
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
    """The exception that ended the run (outcome ``error``), if any."""

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
