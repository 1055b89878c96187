"""Closed-loop simulation: options, the loop, its log, its typed summary, objectives.

See :mod:`redservo.simulation.loop` for the loop and its outcomes,
:mod:`redservo.records.summary` for what counts as a success (the log and summary records
shared with the servo loop live in :mod:`redservo.records`), and
:mod:`redservo.control.objectives` for the composable secondary objectives (re-exported here).
"""

from __future__ import annotations

from redservo.control.objectives import (
    CallableObjective,
    JointLimitForce,
    Objective,
    ObjectiveContext,
    OcclusionAvoidance,
)
from redservo.records import (
    FLAG_COLUMNS,
    OUTCOMES,
    FlagCount,
    LogBuffer,
    Outcome,
    RunSummary,
    SimulationLog,
    flag_warnings,
    summarize,
)
from redservo.simulation.loop import LIMIT_TOLERANCE, SimulationResult, simulate
from redservo.simulation.options import Occlusion, SimulationOptions

__all__ = [
    "FLAG_COLUMNS",
    "LIMIT_TOLERANCE",
    "OUTCOMES",
    "CallableObjective",
    "FlagCount",
    "JointLimitForce",
    "LogBuffer",
    "Objective",
    "ObjectiveContext",
    "Occlusion",
    "OcclusionAvoidance",
    "Outcome",
    "RunSummary",
    "SimulationLog",
    "SimulationOptions",
    "SimulationResult",
    "flag_warnings",
    "simulate",
    "summarize",
]
