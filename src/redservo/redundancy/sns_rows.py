"""SNS with the velocity-damper rows as further saturable constraints.

How ``sns`` honours the distance rows ``G q̇ ≥ b`` (:mod:`redservo.redundancy.distance_rows`):
Algorithm 1 of Flacco, De Luca & Khatib (2012) runs over the stacked constraints
``C = [I; G]`` with the bounds ``[q̇_min, q̇_max]`` for the joints and ``[b, +∞)`` for the
rows. A constraint that the command violates is **saturated** as a joint is: fixed at the
bound it violates (``C_S q̇ = v_S``), and the task is redistributed in the null space of the
saturated constraints, ``P_S = I − C_S⁺ C_S``::

    q̇_N = C_S⁺ v_S + P_S q̇_pref
    q̇(s) = q̇_N + (J1 P_S)⁺ (s ẋ − J1 q̇_N)

(for joint rows alone this is the paper's ``W``-masked update). As in the paper the
constraint that limits the task scale most is saturated next, the best scale ``s*`` seen is
kept, and when ``rank(J1 P_S) < rank J1`` the loop restores ``s*``: the task keeps its
direction and only its magnitude shrinks. ``sns`` first runs its compiled kernel on the
joints alone and takes this path only when that command breaks a distance row.
Units: rad/s or m/s for ``q̇``, m/s for the rows.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.redundancy.base import LawInputs, LawResult
from redservo.redundancy.distance_rows import DistanceRows, row_report
from redservo.redundancy.flags import Event, Flag
from redservo.redundancy.safety import apply_safety

if TYPE_CHECKING:
    from redservo.redundancy.sns import SaturationInNullSpace

__all__ = ["RowSolution", "sns_rows_solve", "with_rows"]

_TOL = 1e-10


class RowSolution(NamedTuple):
    """Result of :func:`sns_rows_solve`."""

    qdot: FloatArray
    """(n,) the command within the joint bounds (rad/s or m/s)."""
    scale: float
    """Task scale ``s`` in [0, 1]."""
    saturated: tuple[int, ...]
    """Saturated constraints: ``i < n`` a joint, ``n + k`` the distance row ``k``."""
    iterations: int
    """Passes of the loop."""


def _scaling(
    a: FloatArray, b: FloatArray, lo: FloatArray, hi: FloatArray, free: FloatArray
) -> tuple[float, int]:
    """Largest ``s ∈ [0, 1]`` with ``lo ≤ a s + b ≤ hi`` on the free rows
    (``getTaskScalingFactor`` of Algorithm 1) and the row to saturate next: among the rows
    broken at ``s = 1``, the first one broken as ``s`` grows (-1: none broken)."""
    tol = _TOL * (1.0 + np.minimum(np.abs(lo), np.abs(hi)))
    lo_t, hi_t = lo - tol, hi + tol
    tiny = np.abs(a) < 1e-14
    with np.errstate(divide="ignore", invalid="ignore"):
        r1, r2 = (lo_t - b) / a, (hi_t - b) / a
    s_lo = np.where(tiny, np.where(b >= lo_t, -np.inf, np.inf), np.minimum(r1, r2))
    s_hi = np.where(tiny, np.where(b <= hi_t, np.inf, -np.inf), np.maximum(r1, r2))
    s_lo, s_hi = s_lo[free], s_hi[free]
    s_min, s_max = float(np.max(s_lo, initial=0.0)), float(np.min(s_hi, initial=1.0))
    s = min(s_max, 1.0) if s_min <= s_max and s_max >= 0.0 else 0.0
    broken = (s_lo > 1.0) | (s_hi < 1.0)
    if not np.any(broken):
        return s, -1
    key = np.where(broken, np.minimum(np.maximum(s_hi, 0.0), 1.0), np.inf)
    return s, int(np.flatnonzero(free)[int(np.argmin(key))])


def sns_rows_solve(
    J1: FloatArray,
    xdot: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    G: FloatArray,
    gb: FloatArray,
    pref: FloatArray | None,
    rcond: float,
) -> RowSolution:
    """The module's Algorithm 1 over the joints and the distance rows.

    Args:
        J1: (m, n) task Jacobian; xdot: (m,) task velocity.
        lo, hi: (n,) joint-velocity bounds (rad/s or m/s), ``lo ≤ hi``.
        G: (r, n) distance Jacobians; gb: (r,) their lower bounds (m/s).
        pref: (n,) preferred joint velocity (the initial ``q̇_N``), or None.
        rcond: Relative singular-value cut-off of the pseudo-inverses.
    """
    n = J1.shape[1]
    C = np.vstack([np.eye(n), G])
    low = np.concatenate([lo, gb])
    up = np.concatenate([hi, np.full(gb.size, np.inf)])
    p = np.zeros(n) if pref is None else pref
    cut = rcond * max(float(np.linalg.norm(J1, 2)), 1e-300)
    rank1 = np.linalg.matrix_rank(J1, tol=cut)
    sat: list[int] = []
    vals: list[float] = []
    best = (-1.0, np.zeros(n), np.zeros(n))
    it = 0
    for it in range(1, C.shape[0] + 2):
        P, qN = np.eye(n), p
        if sat:
            Cp = np.linalg.pinv(C[sat], rcond=rcond)
            P = np.eye(n) - Cp @ C[sat]
            qN = Cp @ np.asarray(vals) + P @ p
        JP = J1 @ P
        if sat and np.linalg.matrix_rank(JP, tol=cut) < rank1:
            break  # the free constraints can no longer carry the task: restore s*
        JPp = np.linalg.pinv(JP, rcond=rcond)
        a, b = JPp @ xdot, qN - JPp @ (J1 @ qN)
        free = np.ones(C.shape[0], dtype=bool)
        free[sat] = False
        s, j = _scaling(C @ a, C @ b, low, up, free)
        if j < 0:
            q, f = _keep_rows(np.clip(a + b, lo, hi), lo, hi, G, gb)
            return RowSolution(q, f, tuple(sorted(sat)), it)
        if s > best[0]:
            best = (s, a, b)
        v = float(C[j] @ (a + b))
        sat.append(j)
        vals.append(float(up[j]) if v > up[j] else float(low[j]))
    s, a, b = best
    s = max(s, 0.0)
    q, f = _keep_rows(np.clip(s * a + b, lo, hi), lo, hi, G, gb)
    return RowSolution(q, s * f, tuple(sorted(sat)), it)


def _keep_rows(
    qdot: FloatArray, lo: FloatArray, hi: FloatArray, G: FloatArray, gb: FloatArray
) -> tuple[FloatArray, float]:
    """``(f q̇, f)`` with the largest ``f`` in [0, 1] that keeps every distance row
    ``G q̇ ≥ gb`` (m/s), when the restored or clipped command breaks one and the zero command
    keeps them all (every ``gb ≤ 0`` and ``lo ≤ 0 ≤ hi``: a uniform scaling towards zero then
    keeps the joint bounds too); ``(q̇, 1)`` otherwise (the distance shield after the law
    still guards a row zero cannot keep)."""
    g = G @ qdot
    broken = g < gb
    if not broken.any() or np.any(gb > 0.0) or np.any(lo > 0.0) or np.any(hi < 0.0):
        return qdot, 1.0
    f = float(np.clip(np.min(gb[broken] / g[broken]), 0.0, 1.0))
    return f * qdot, f


def with_rows(
    law: SaturationInNullSpace,
    x: LawInputs,
    rows: DistanceRows,
    kernel_out: tuple[Any, ...],
    res: LawResult,
) -> LawResult:
    """``law``'s command again with the distance ``rows`` (:func:`sns_rows_solve` on the
    bounds its kernel used, ``kernel_out``), through the safety layer; ``res`` (the command
    without them) carries the diagnostics the new ones replace."""
    lo, hi = kernel_out[-2], kernel_out[-1]
    sol = sns_rows_solve(x.J1, -x.lam * x.e_eff, lo, hi, rows.G, rows.b, x.secondary, law.rcond)
    safe = apply_safety(sol.qdot, x.q, x.limits, x.dt, qdot_prev=x.qdot_prev, shield=law.shield)
    n = x.J1.shape[1]
    joints = tuple(i for i in sol.saturated if i < n)
    pairs = [rows.names[i - n] for i in sol.saturated if i >= n]
    info = [f"distance rows saturated: {', '.join(pairs) or 'none'} ({len(rows.b)} active)"]
    gap = row_report(rows, safe.qdot)
    info += [gap] if gap else []
    d = res.diagnostics
    why = f"task scaled by {sol.scale:.3g} to keep the distance rows and the joint bounds"
    scaled = (Event(Flag.TASK_SCALED, sol.scale, why),) if sol.scale < 1.0 else ()
    diag = dataclasses.replace(
        d,
        critical=(joints,) if joints else (),
        iterations=sol.iterations,
        overconstrained=sol.scale < 1.0,
        scale=sol.scale,
        events=(*scaled, *safe.events),
        info=(*d.info, *info),
    )
    return LawResult(safe.qdot, diag)
