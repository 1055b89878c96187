"""The row layout of the packed joint limits that the kernels take (pure constants).

A kernel argument ``lp`` is one (ROWS, n) float64 array whose rows are, in this order,
``q̄_min, q̄_max, q̃_min, q̃_max, Δq̄, centre, q_safe_min, q_safe_max, q̇_max (inf if none),
q̈_max (inf if none), ρ Δq̄`` (joint units: m or rad, per s, per s²). The object layer
builds it from a :class:`~redservo.JointLimits` (:func:`redservo.redundancy.packs.limits_pack`);
this module imports nothing, so that the kernels stay below every public object.
"""

from __future__ import annotations

__all__ = [
    "AMAX",
    "CENTER",
    "QT_MAX",
    "QT_MIN",
    "Q_MAX",
    "Q_MIN",
    "RANGE",
    "RHO_RANGE",
    "ROWS",
    "SAFE_MAX",
    "SAFE_MIN",
    "VMAX",
]

Q_MIN, Q_MAX, QT_MIN, QT_MAX, RANGE, CENTER, SAFE_MIN, SAFE_MAX, VMAX, AMAX, RHO_RANGE = range(11)
"""Rows of the packed limits (module docstring)."""

ROWS = 11
"""Number of rows of the packed limits."""
