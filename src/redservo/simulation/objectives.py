"""Composable secondary objectives (kept here for earlier imports).

They live in :mod:`redservo.control.objectives`, next to the :class:`~redservo.Controller`
that sums them, so that the servo loop of a real arm uses them without importing the
simulator. See that module for what an objective may rely on in each loop.
"""

from __future__ import annotations

from redservo.control.objectives import (
    CallableObjective,
    JointLimitForce,
    Objective,
    ObjectiveContext,
    Occlusion,
    OcclusionAvoidance,
    occlusion_state,
    visible_points,
)

__all__ = [
    "CallableObjective",
    "JointLimitForce",
    "Objective",
    "ObjectiveContext",
    "Occlusion",
    "OcclusionAvoidance",
    "occlusion_state",
    "visible_points",
]
