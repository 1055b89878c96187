"""Plain-array forms of the public objects that the laws hand to the kernels (no numba here).

:func:`limits_pack` turns a :class:`~redservo.JointLimits` into one (11, n) float64 array
(the rows of :mod:`redservo.kernels.pack`) plus flags, cached per instance
(``JointLimits`` is immutable), so that a law call passes one array instead of a dozen.
This module sits on the object layer (it knows :class:`~redservo.JointLimits` and the
kernels' row layout, nothing else), so that the laws use it without importing the binding
(:mod:`redservo.binding`), which sits above them.
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels.pack import (
    AMAX,
    CENTER,
    Q_MAX,
    Q_MIN,
    QT_MAX,
    QT_MIN,
    RANGE,
    RHO_RANGE,
    ROWS,
    SAFE_MAX,
    SAFE_MIN,
    VMAX,
)
from redservo.limits import JointLimits

__all__ = ["LimitsPack", "limits_pack"]


class LimitsPack(NamedTuple):
    """A :class:`~redservo.JointLimits` as the kernels take it."""

    rows: FloatArray
    """(11, n) rows listed in :mod:`redservo.kernels.pack` (units of the joints)."""
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
    rows = np.empty((ROWS, n))
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
