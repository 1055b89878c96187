"""Joint-limit quantities of CM01 on packed limits (:func:`redservo.redundancy.packs.limits_pack`).

The same formulas as the methods of :class:`~redservo.JointLimits` (limits.py documents
them): the excess ``s_i`` and gradient ``e2_i = s_i/Δq̄_i`` (CM01 eqs. 5-6), the critical
test of the iterative scheme (docs/formulas.md §7.2), the smoothing gains γ (eq. 17
corrected) and the margin as a fraction of the range. Units: joint units (m or rad).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.pack import CENTER, Q_MAX, Q_MIN, QT_MAX, QT_MIN, RANGE, RHO_RANGE

__all__ = ["critical", "gamma", "gradient", "in_band", "margin"]


@kernel
def gradient(q: Any, lp: Any) -> Any:
    """(n,) ``e2 = (∂h_s/∂q)^T``, ``e2_i = s_i / Δq̄_i`` (CM01 eq. 6); dimensionless."""
    n = q.shape[0]
    e2 = np.empty(n)
    for i in range(n):
        if q[i] > lp[QT_MAX, i]:
            s = q[i] - lp[QT_MAX, i]
        elif q[i] < lp[QT_MIN, i]:
            s = q[i] - lp[QT_MIN, i]
        else:
            s = 0.0
        e2[i] = s / lp[RANGE, i]
    return e2


@kernel
def in_band(q: Any, lp: Any) -> Any:
    """(n,) booleans: ``q_i`` between its threshold and its limit (or beyond)."""
    n = q.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        out[i] = q[i] <= lp[QT_MIN, i] or q[i] >= lp[QT_MAX, i]
    return out


@kernel
def critical(q: Any, q_hat: Any, lp: Any) -> Any:
    """(n,) booleans: ``q̂_k`` in the band (or beyond) and moving toward that limit."""
    n = q.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        qh = q_hat[i]
        band = max(qh - lp[QT_MAX, i], lp[QT_MIN, i] - qh) >= 0.0
        out[i] = band and (qh - q[i]) * (qh - lp[CENTER, i]) > 0.0
    return out


@kernel
def gamma(q_hat: Any, lp: Any) -> Any:
    """(n,) smoothing gains γ of CM01 eq. 17 (corrected), in [0, 1]."""
    n = q_hat.shape[0]
    g = np.empty(n)
    for i in range(n):
        v = max(lp[QT_MIN, i] - q_hat[i], q_hat[i] - lp[QT_MAX, i]) / lp[RHO_RANGE, i]
        g[i] = max(min(v, 1.0), 0.0)
    return g


@kernel
def margin(q: Any, lp: Any) -> Any:
    """(n,) distance to the nearest limit as a fraction of the range (0.5 at mid-range)."""
    n = q.shape[0]
    out = np.empty(n)
    for i in range(n):
        out[i] = min(q[i] - lp[Q_MIN, i], lp[Q_MAX, i] - q[i]) / lp[RANGE, i]
    return out
