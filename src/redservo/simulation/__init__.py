"""Closed-loop simulation: options, the loop, its log, its typed summary, objectives.

See :mod:`redservo.simulation.loop` for the loop and its outcomes,
:mod:`redservo.simulation.summary` for what counts as a success, and
:mod:`redservo.simulation.objectives` for the composable secondary objectives.
"""

from __future__ import annotations

from redservo.simulation.loop import LIMIT_TOLERANCE, SimulationResult, simulate
from redservo.simulation.objectives import (
    CallableObjective,
    JointLimitForce,
    Objective,
    ObjectiveContext,
    OcclusionAvoidance,
)
from redservo.simulation.options import Occlusion, SimulationOptions
from redservo.simulation.runlog import FLAG_COLUMNS, LogBuffer, SimulationLog
from redservo.simulation.summary import (
    OUTCOMES,
    FlagCount,
    Outcome,
    RunSummary,
    flag_warnings,
    summarize,
)

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
