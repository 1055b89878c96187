"""SNS over the joints and the velocity-damper rows, compiled: ``sns``'s distance rows.

:func:`sns_rows_solve` is Algorithm 1 of Flacco, De Luca & Khatib (2012) over the stacked
constraints ``C = [I; G]`` as :mod:`redservo.redundancy.sns_rows` states it (which calls
it), with the task SVD of :func:`redservo.kernels.linalg.task_svd` for every
pseudo-inverse and rank (numpy's rules: ``A⁺`` keeps the singular values above ``rcond``
times the largest, ``rank(·, tol)`` counts those above ``tol``). :func:`sns_row_step` is
the law's step with the rows as the campaign loop runs it: the command of the ``sns`` step
kernel, and where it breaks a row, Algorithm 1 again with the rows on the law's own bounds,
then the safety layer; the law object calls the same kernels, so both paths give the same
command to the bit. Units: rad/s or m/s for ``q̇``, m/s for the rows.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.events import safety_events
from redservo.kernels.flagbits import TASK_SCALED
from redservo.kernels.linalg import matvec, task_svd
from redservo.kernels.loop_rows import rows_met
from redservo.kernels.safety import apply_safety
from redservo.kernels.sns import sns_velocity_bounds

__all__ = ["sns_row_step", "sns_rows_solve"]

TOL = 1e-10
"""Relative tolerance of a bound in the scaling (``_TOL`` of redundancy/sns_rows.py)."""
RCOND, SHIELD, HAS_V, HAS_A, V_MAX, A_MAX, MARGIN = 0, 0, 2, 3, 0, 1, 2
"""The slots of ``sns``'s options in the law pack (``SaturationInNullSpace.SLOTS``:
``rcond`` f0, ``shield`` i0, ``has_v_max`` i2, ``has_a_max`` i3, ``v_max`` v0, ``a_max``
v1, ``margin`` f2; a test checks them)."""


@kernel
def _scaling(a: Any, b: Any, lo: Any, hi: Any, free: Any) -> Any:
    """``(s, j)``: the largest ``s ∈ [0, 1]`` with ``lo ≤ a s + b ≤ hi`` on the free rows and
    the row to saturate next, the first broken as ``s`` grows (-1: none broken at s = 1)."""
    s_min, s_max = 0.0, 1.0
    j, key = -1, np.inf
    for i in range(a.shape[0]):
        if not free[i]:
            continue
        tol = TOL * (1.0 + min(abs(lo[i]), abs(hi[i])))
        lo_t, hi_t = lo[i] - tol, hi[i] + tol
        if abs(a[i]) < 1e-14:
            s_lo = -np.inf if b[i] >= lo_t else np.inf
            s_hi = np.inf if b[i] <= hi_t else -np.inf
        else:
            r1, r2 = (lo_t - b[i]) / a[i], (hi_t - b[i]) / a[i]
            s_lo, s_hi = min(r1, r2), max(r1, r2)
        s_min, s_max = max(s_min, s_lo), min(s_max, s_hi)
        if (s_lo > 1.0 or s_hi < 1.0) and min(max(s_hi, 0.0), 1.0) < key:
            j, key = i, min(max(s_hi, 0.0), 1.0)
    s = min(s_max, 1.0) if s_min <= s_max and s_max >= 0.0 else 0.0
    return s, j


@kernel
def _keep_rows(qdot: Any, lo: Any, hi: Any, G: Any, gb: Any) -> Any:
    """``(f q̇, f)``, the largest ``f`` in [0, 1] keeping every row, when the zero command
    keeps them all and the bounds (``_keep_rows`` of redundancy/sns_rows.py); else ``(q̇, 1)``."""
    g = matvec(G, qdot)
    f, broken = 1.0, False
    for k in range(gb.shape[0]):
        if gb[k] > 0.0:
            return qdot, 1.0
        if g[k] < gb[k]:
            broken = True
            f = min(f, gb[k] / g[k])
    for i in range(lo.shape[0]):
        if lo[i] > 0.0 or hi[i] < 0.0:
            return qdot, 1.0
    if not broken:
        return qdot, 1.0
    f = min(max(f, 0.0), 1.0)
    return f * qdot, f


@kernel
def _null_step(C: Any, sat: Any, ns: int, vals: Any, p: Any, rcond: float) -> Any:
    """``(P_S, q̇_N)``: ``P_S = I − C_S⁺ C_S``, ``q̇_N = C_S⁺ v_S + P_S p`` (``p`` without
    a saturated constraint)."""
    n = p.shape[0]
    P = np.eye(n)
    if ns == 0:
        return P, p.copy()
    Cs = np.empty((ns, n))
    for k in range(ns):
        Cs[k] = C[sat[k]]
    Cp = task_svd(Cs, rcond, 0.0)[4]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(ns):
                acc += Cp[i, k] * Cs[k, j]
            P[i, j] -= acc
    qN = matvec(Cp, vals[:ns]) + matvec(P, p)
    return P, qN


@kernel
def _task_part(J1: Any, P: Any, qN: Any, xdot: Any, rcond: float, cut: float) -> Any:
    """``(a, b, rank)``: ``q̇(s) = a s + b`` with ``a = (J1 P)⁺ ẋ``, ``b = q̇_N − (J1 P)⁺ J1
    q̇_N``, and ``rank(J1 P)`` at the absolute cut-off ``cut``."""
    m, n = J1.shape
    JP = np.zeros((m, n))
    for i in range(m):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += J1[i, k] * P[k, j]
            JP[i, j] = acc
    _, sigma, _, _, JPp, _ = task_svd(JP, rcond, 0.0)
    rank = 0
    for i in range(sigma.shape[0]):
        if sigma[i] > cut:
            rank += 1
    a = matvec(JPp, xdot)
    b = qN - matvec(JPp, matvec(J1, qN))
    return a, b, rank


@kernel
def sns_rows_solve(
    J1: Any, xdot: Any, lo: Any, hi: Any, G: Any, gb: Any, pref: Any, has_pref: bool, rcond: float
) -> Any:
    """Algorithm 1 over the joints and the rows (redundancy/sns_rows.py, ``sns_rows_solve``):
    ``(q̇, scale, saturated (N,) int64, count, iterations)``, the saturated constraints
    (``i < n`` a joint, ``n + k`` the row ``k``) in their first ``count`` entries."""
    n, r = J1.shape[1], gb.shape[0]
    N = n + r
    C, low, up = np.zeros((N, n)), np.empty(N), np.empty(N)
    for i in range(n):
        C[i, i], low[i], up[i] = 1.0, lo[i], hi[i]
    for k in range(r):
        C[n + k], low[n + k], up[n + k] = G[k], gb[k], np.inf
    p = pref.copy() if has_pref else np.zeros(n)
    sigma1 = task_svd(J1, rcond, 0.0)[1]
    cut = rcond * max(sigma1[0] if sigma1.shape[0] > 0 else 0.0, 1e-300)
    rank1 = 0
    for i in range(sigma1.shape[0]):
        if sigma1[i] > cut:
            rank1 += 1
    sat, vals, ns = np.zeros(N + 1, dtype=np.int64), np.zeros(N + 1), 0
    free = np.ones(N, dtype=np.bool_)
    best_s, best_a, best_b = -1.0, np.zeros(n), np.zeros(n)
    it = 0
    for it in range(1, N + 2):
        P, qN = _null_step(C, sat, ns, vals, p, rcond)
        a, b, rank = _task_part(J1, P, qN, xdot, rcond, cut)
        if ns > 0 and rank < rank1:
            break  # the free constraints can no longer carry the task: restore s*
        s, j = _scaling(matvec(C, a), matvec(C, b), low, up, free)
        if j < 0:
            q, f = _keep_rows(np.minimum(np.maximum(a + b, lo), hi), lo, hi, G, gb)
            return q, f, np.sort(sat[:ns]), ns, it
        if s > best_s:
            best_s, best_a, best_b = s, a, b
        v = 0.0
        for i in range(n):
            v += C[j, i] * (a[i] + b[i])
        sat[ns], vals[ns] = j, up[j] if v > up[j] else low[j]
        free[j] = False
        ns += 1
    s = max(best_s, 0.0)
    q, f = _keep_rows(np.minimum(np.maximum(s * best_a + best_b, lo), hi), lo, hi, G, gb)
    return q, s * f, np.sort(sat[:ns]), ns, it


@kernel
def sns_row_step(qd: Any, J1: Any, e1: Any, ff: Any, has_ff: bool, q: Any, *ctx: Any) -> Any:
    """``sns``'s command ``qd`` (the step kernel's) kept when it meets every row; else the
    law's ``with_rows`` (redundancy/sns_rows.py): Algorithm 1 with the rows ``G q̇ ≥ b`` on
    its SNS bounds, then the safety layer: ``(q̇, bits, replaced)``, ``bits`` the flags of
    the new command (the task scale and the safety layer's, as the law reports them).
    ``ctx`` = ``(prev, sec, law, limits, sim, G, b)``, the packs of the campaign loop."""
    prev, sec, law, limits, sim, G, b = ctx
    if b.shape[0] == 0 or rows_met(G, b, qd):
        return qd, 0, False
    _, fopt, iopt, vopt, _ = law
    lp, has_v, has_a, _, _ = limits
    lam, dt = sim[0], sim[1]
    m, n = J1.shape
    lo, hi, _ = sns_velocity_bounds(
        q, lp, dt, vopt[V_MAX], iopt[HAS_V] != 0, vopt[A_MAX], iopt[HAS_A] != 0, fopt[MARGIN]
    )
    xdot = np.empty(m)
    for i in range(m):
        xdot[i] = -lam * (e1[i] + ff[i] / lam if has_ff else e1[i])  # −λ e_eff
    has_sec = sec.shape[0] > 0
    pref = sec if has_sec else np.zeros(n)
    x, scale, _, _, _ = sns_rows_solve(J1, xdot, lo, hi, G, b, pref, has_sec, fopt[RCOND])
    shield = iopt[SHIELD] != 0
    qs, bad, sc, over_v, dropped, change, acted, worst, exc, past, _ = apply_safety(
        x, q, lp, has_v, has_a, dt, prev, True, shield, np.zeros(n), False
    )
    bits = safety_events(bad, sc, over_v, dropped, change, acted, worst, exc, past)[0]
    if scale < 1.0:
        bits |= 1 << TASK_SCALED
    return qs, bits, True
