"""The typed records of a run, shared by every loop: the per-step log and the run summary.

The simulator (:mod:`redservo.simulation`), the servo loop of a real arm
(:mod:`redservo.hardware`) and the campaigns write the same records, so reports, plots,
the viewer and replays read every run the same way. They depend on the laws' diagnostics
and the task's state, never on a loop: ``hardware/`` uses them without importing the
simulator (tests/test_layers.py).

* :class:`SimulationLog` / :class:`LogBuffer` (:mod:`redservo.records.runlog`): one row per
  control step (time in s, joints in rad or m, commands in rad/s or m/s, features, errors,
  diagnostics and flags);
* :class:`RunSummary` and :func:`summarize` (:mod:`redservo.records.summary`): the outcome,
  what counts as a success, the rate and margin statistics and the flag counts;
* :func:`verdict` / :func:`outcome_text` (:mod:`redservo.records.verdict`): the success verdict
  in words (why a run is no success), what every place that shows an outcome prints;
* :class:`SimulationResult` (:mod:`redservo.records.result`): one run's outcome, summary and
  log, and :meth:`~SimulationResult.save` to a run directory (out of the simulation loop:
  a replay or a reproduction saves the same record).
"""

from __future__ import annotations

from redservo.records.result import SimulationResult
from redservo.records.runlog import FLAG_COLUMNS, LogBuffer, SimulationLog
from redservo.records.summary import (
    OUTCOMES,
    FlagCount,
    Outcome,
    RunSummary,
    flag_warnings,
    summarize,
)
from redservo.records.verdict import failure_reasons, outcome_text, verdict

__all__ = [
    "FLAG_COLUMNS",
    "OUTCOMES",
    "FlagCount",
    "LogBuffer",
    "Outcome",
    "RunSummary",
    "SimulationLog",
    "SimulationResult",
    "failure_reasons",
    "flag_warnings",
    "outcome_text",
    "summarize",
    "verdict",
]
