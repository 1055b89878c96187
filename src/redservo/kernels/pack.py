"""Plain-array forms of the objects the kernels need (pure Python, no numba).

:func:`limits_pack` turns a :class:`~redservo.JointLimits` into one (11, n) float64 array
(rows below) plus flags, cached per instance (``JointLimits`` is immutable), so that a
law call passes one array instead of a dozen.
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.limits import JointLimits

__all__ = [
    "AMAX",
    "CENTER",
    "QT_MAX",
    "QT_MIN",
    "Q_MAX",
    "Q_MIN",
    "RANGE",
    "RHO_RANGE",
    "SAFE_MAX",
    "SAFE_MIN",
    "VMAX",
    "LimitsPack",
    "limits_pack",
]

Q_MIN, Q_MAX, QT_MIN, QT_MAX, RANGE, CENTER, SAFE_MIN, SAFE_MAX, VMAX, AMAX, RHO_RANGE = range(11)
"""Rows of the packed limits: ``q̄_min, q̄_max, q̃_min, q̃_max, Δq̄, centre, q_safe_min,
q_safe_max, q̇_max (inf if none), q̈_max (inf if none), ρ Δq̄``."""


class LimitsPack(NamedTuple):
    """A :class:`~redservo.JointLimits` as the kernels take it."""

    rows: FloatArray
    """(11, n) rows listed in the module docstring."""
    has_v: bool
    """Velocity limits are given."""
    has_a: bool
    """Acceleration limits are given."""


_CACHE: weakref.WeakKeyDictionary[JointLimits, LimitsPack] = weakref.WeakKeyDictionary()


def limits_pack(limits: JointLimits) -> LimitsPack:
    """Return the packed form of ``limits`` (computed once per instance)."""
    hit = _CACHE.get(limits)
    if hit is not None:
        return hit
    n = limits.n
    v, a = limits.qdot_max, limits.qddot_max
    rows = np.empty((11, n))
    rows[Q_MIN] = limits.q_min
    rows[Q_MAX] = limits.q_max
    rows[QT_MIN] = limits.q_tilde_min
    rows[QT_MAX] = limits.q_tilde_max
    rows[RANGE] = limits.range
    rows[CENTER] = limits.center
    rows[SAFE_MIN] = limits.safe_min
    rows[SAFE_MAX] = limits.safe_max
    rows[VMAX] = np.inf if v is None else v
    rows[AMAX] = np.inf if a is None else a
    rows[RHO_RANGE] = limits.rho * limits.range
    pack = LimitsPack(rows, v is not None, a is not None)
    _CACHE[limits] = pack
    return pack
