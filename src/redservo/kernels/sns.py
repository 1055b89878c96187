"""Kernels of Saturation in the Null Space (Flacco, De Luca & Khatib 2012).

Algorithm 1 with the masking fix, its velocity bounds, and the whole ``sns`` law with the
safety box; formulas and decisions in :mod:`redservo.redundancy.sns`, which wraps them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.linalg import matvec, task_svd
from redservo.kernels.pack import Q_MAX, Q_MIN
from redservo.kernels.safety import command_box, exact_position_fix, intersect_boxes

__all__ = ["sns", "sns_solve", "sns_velocity_bounds", "task_scaling", "violation_tol"]

VIOLATION_RTOL = 1e-10


@kernel
def sns_velocity_bounds(
    q: Any,
    lp: Any,
    dt: float,
    v: Any,
    has_v: bool,
    a: Any,
    has_a: bool,
    margin: float,
) -> Any:
    """``(q̇_min, q̇_max, bad)`` of SNS; ``bad`` is the first joint whose lower bound exceeds
    its upper bound (-1 if none)."""
    n = q.shape[0]
    lo = np.empty(n)
    hi = np.empty(n)
    bad = -1
    for i in range(n):
        d_lo = q[i] - lp[Q_MIN, i]
        d_hi = lp[Q_MAX, i] - q[i]
        low = -d_lo / dt
        h = d_hi / dt
        if has_v:
            low = max(low, -v[i])
            h = min(h, v[i])
        if has_a:
            low = max(low, -np.sqrt(2.0 * a[i] * max(d_lo, 0.0)))
            h = min(h, np.sqrt(2.0 * a[i] * max(d_hi, 0.0)))
        lo[i] = margin * low
        hi[i] = margin * h
        if bad < 0 and lo[i] > hi[i]:
            bad = i
    return lo, hi, bad


@kernel
def violation_tol(lo: Any, hi: Any) -> Any:
    """(n,) ``1e-10 (1 + max(|lo|, |hi|))``."""
    n = lo.shape[0]
    tol = np.empty(n)
    for i in range(n):
        tol[i] = VIOLATION_RTOL * (1.0 + max(abs(lo[i]), abs(hi[i])))
    return tol


@kernel
def task_scaling(a: Any, b: Any, lo: Any, hi: Any, free: Any, tol: Any) -> Any:
    """``(s_f, j)``: the largest feasible task scale for ``q̇(s) = a s + b`` over the free
    joints only (masking fix), and the free joint limiting it (-1 if none)."""
    n = a.shape[0]
    k = -1
    smax = np.inf
    smin = -np.inf
    for i in range(n):
        if not free[i]:
            continue
        s_lo = -np.inf
        s_hi = np.inf
        if a[i] != 0.0:
            s1 = (lo[i] - b[i]) / a[i]
            s2 = (hi[i] - b[i]) / a[i]
            s_lo = min(s1, s2)
            s_hi = max(s1, s2)
        elif b[i] < lo[i] - tol[i] or b[i] > hi[i] + tol[i]:
            s_hi = -np.inf
        if k < 0 or s_hi < smax:
            k = i
            smax = s_hi
        smin = max(smin, s_lo)
    if k < 0:
        return 0.0, -1
    if smin > smax or smax < 0.0 or smin > 1.0:
        return 0.0, k
    return min(smax, 1.0), k


@kernel
def _masked_pinv(J: Any, w: Any, rcond: float) -> Any:
    """``(rank, (J W)⁺)`` with ``W = diag(w)``."""
    m, n = J.shape
    JW = np.empty((m, n))
    for i in range(m):
        for j in range(n):
            JW[i, j] = J[i, j] * w[j]
    _, _, _, rank, pinv, _ = task_svd(JW, rcond, 0.0)
    return rank, pinv


@kernel
def _solution(J: Any, pinv: Any, xdot: Any, qn: Any, s: float) -> Any:
    """``q̇ = q̇_N + (J W)⁺ (s ẋ - J q̇_N)`` with ``pinv = (J W)⁺``."""
    m, n = J.shape
    Jq = matvec(J, qn)
    rhs = np.empty(m)
    for i in range(m):
        rhs[i] = s * xdot[i] - Jq[i]
    corr = matvec(pinv, rhs)
    qdot = np.empty(n)
    for i in range(n):
        qdot[i] = qn[i] + corr[i]
    return qdot


@kernel
def clip_to_box(qdot: Any, lo: Any, hi: Any, w: Any) -> Any:
    """Clip the solved ``q̇`` to ``[lo, hi]`` (rad/s or m/s) and read the joint mask ``w``.

    Returns:
        ``(out, clipped, saturated, free_count)``: the clipped command, the largest change
        of the clip (rad/s or m/s), (n,) booleans of the saturated joints (``w = 0``) and
        the number of free ones.
    """
    n = qdot.shape[0]
    out = np.empty(n)
    clipped = 0.0
    saturated = np.empty(n, dtype=np.bool_)
    free_count = 0
    for i in range(n):
        out[i] = min(max(qdot[i], lo[i]), hi[i])
        clipped = max(clipped, abs(out[i] - qdot[i]))
        saturated[i] = w[i] == 0.0
        if w[i] != 0.0:
            free_count += 1
    return out, clipped, saturated, free_count


@kernel
def sns_solve(J: Any, xdot: Any, lo: Any, hi: Any, pref: Any, has_pref: bool, rcond: float) -> Any:
    """Algorithm 1 of Flacco et al. 2012 with the masking fix (redundancy/sns.py).

    Returns:
        ``(q̇, s, saturated, iterations, free_null_dim, restored, clipped, rank_J)``:
        q̇ clipped to the bounds, the task scale, (n,) booleans of the saturated joints,
        the loop passes, ``#free - rank(J W)``, whether the best scale was restored, the
        largest change of the final clip and the rank of J.
    """
    n = J.shape[1]
    tol = violation_tol(lo, hi)
    w = np.ones(n)
    qn = pref.copy() if has_pref else np.zeros(n)
    s = 1.0
    best_s = 0.0
    best_w = np.ones(n)
    best_qn = np.zeros(n)  # fallback: q̇ = 0
    restored = False
    iterations = 0
    rank, pinv = _masked_pinv(J, w, rcond)
    qdot = _solution(J, pinv, xdot, qn, s)
    rank_J = rank  # W = I here: the decomposition of J itself
    best_rank, best_pinv = rank, pinv  # (J W)⁺ of best_w: restoring needs no new SVD
    for it in range(1, n + 2):
        iterations = it
        violated = False
        for i in range(n):
            if qdot[i] < lo[i] - tol[i] or qdot[i] > hi[i] + tol[i]:
                violated = True
        if not violated:
            break
        a = matvec(pinv, xdot)
        b = np.empty(n)
        free = np.empty(n, dtype=np.bool_)
        for i in range(n):
            b[i] = qdot[i] - a[i]
            free[i] = w[i] > 0.0
        sf, j = task_scaling(a, b, lo, hi, free, tol)
        if sf > best_s:
            best_s = sf
            best_w = w.copy()
            best_qn = qn.copy()
            best_rank, best_pinv = rank, pinv
        if j < 0:  # no free joint left
            restored = True
        else:
            w[j] = 0.0
            if qdot[j] > hi[j] + tol[j]:
                qn[j] = hi[j]
            elif qdot[j] < lo[j] - tol[j]:
                qn[j] = lo[j]
            else:
                qn[j] = hi[j] if a[j] > 0.0 else lo[j]
            rank, pinv = _masked_pinv(J, w, rcond)
            qdot = _solution(J, pinv, xdot, qn, s)
            restored = rank < rank_J
        if restored or it == n + 1:
            restored = True
            s = best_s
            w = best_w
            qn = best_qn
            rank, pinv = best_rank, best_pinv
            qdot = _solution(J, pinv, xdot, qn, s)
            break
    out, clipped, saturated, free_count = clip_to_box(qdot, lo, hi, w)
    return out, s, saturated, iterations, free_count - rank, restored, clipped, rank_J


@kernel
def inconsistent_outputs(n: int, bad: int, lo_s: Any, hi_s: Any) -> Any:
    """:func:`sns`'s outputs when joint ``bad``'s SNS bounds are inconsistent.

    A zero command (rad/s or m/s) and zero counts; only ``bad`` and the bounds
    ``lo_s``/``hi_s`` (rad/s or m/s, for the error message) are meaningful.
    """
    return (
        np.zeros(n),
        0.0,
        np.zeros(n, dtype=np.bool_),
        0,
        0,
        False,
        0.0,
        0,
        False,
        bad,
        lo_s,
        hi_s,
    )


@kernel
def sns(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    prev: Any,
    has_prev: bool,
    sec: Any,
    has_sec: bool,
    v_opt: Any,
    has_v_opt: bool,
    a_opt: Any,
    has_a_opt: bool,
    margin: float,
    rcond: float,
    shield: bool = True,
) -> Any:
    """The ``sns`` law: its bounds ∩ the safety box, Algorithm 1, the exact position fix.

    ``shield``: whether the law's position shield is on (where the rate and position boxes
    miss, it decides which wins: :func:`~redservo.kernels.safety.command_box`).

    Returns:
        ``(q̇, s, saturated, iterations, free_null_dim, restored, clipped, rank_J,
        clip_noted, bad, lo_sns, hi_sns)``: :func:`sns_solve`'s outputs with q̇ moved by the
        exact fix, whether the final clip exceeded the violation tolerance, and the first
        joint with inconsistent SNS bounds (-1 if none; then only ``lo_sns``/``hi_sns`` are
        meaningful, for the error message).
    """
    n = q.shape[0]
    lo_s, hi_s, bad = sns_velocity_bounds(q, lp, dt, v_opt, has_v_opt, a_opt, has_a_opt, margin)
    if bad >= 0:
        return inconsistent_outputs(n, bad, lo_s, hi_s)
    clo, chi = command_box(q, lp, has_v, has_a, dt, prev, has_prev, shield)
    lo, hi = intersect_boxes(lo_s, hi_s, clo, chi)
    xdot = np.empty(e.shape[0])
    for i in range(e.shape[0]):
        xdot[i] = -lam * e[i]
    qdot, s, saturated, iterations, free_null, restored, clipped, rank_J = sns_solve(
        J1, xdot, lo, hi, sec, has_sec, rcond
    )
    tol = violation_tol(lo, hi)
    noted = False
    for i in range(n):
        noted = noted or clipped > tol[i]
    fixed, _ = exact_position_fix(q, qdot, dt, lp)
    return (
        fixed,
        s,
        saturated,
        iterations,
        free_null,
        restored,
        clipped,
        rank_J,
        noted,
        -1,
        lo_s,
        hi_s,
    )
