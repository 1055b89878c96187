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
joints alone and takes this path only when that command breaks a distance row. The
algorithm is compiled (:mod:`redservo.kernels.sns_rows`, with the task SVD kernel for every
pseudo-inverse and rank) and the campaign loop calls the same kernels, so the law object
and the loop give the same command to the bit.
Units: rad/s or m/s for ``q̇``, m/s for the rows.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.redundancy.base import LawInputs, LawResult
from redservo.redundancy.distance_rows import DistanceRows, row_report
from redservo.redundancy.flags import Event, Flag
from redservo.redundancy.safety import apply_safety

if TYPE_CHECKING:
    from redservo.kernels import sns_rows as _K
    from redservo.redundancy.sns import SaturationInNullSpace
else:
    _K = lazy("sns_rows")

__all__ = ["RowSolution", "sns_rows_solve", "with_rows"]


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
    """The module's Algorithm 1 over the joints and the distance rows, by the compiled
    kernel the campaign loop calls too (:func:`redservo.kernels.sns_rows.sns_rows_solve`).

    Args:
        J1: (m, n) task Jacobian; xdot: (m,) task velocity.
        lo, hi: (n,) joint-velocity bounds (rad/s or m/s), ``lo ≤ hi``.
        G: (r, n) distance Jacobians; gb: (r,) their lower bounds (m/s).
        pref: (n,) preferred joint velocity (the initial ``q̇_N``), or None.
        rcond: Relative singular-value cut-off of the pseudo-inverses.
    """
    c = np.ascontiguousarray
    n = J1.shape[1]
    p = np.zeros(n) if pref is None else c(pref, dtype=np.float64)
    q, scale, sat, count, it = _K.sns_rows_solve(
        c(J1, dtype=np.float64),
        c(xdot, dtype=np.float64),
        c(lo, dtype=np.float64),
        c(hi, dtype=np.float64),
        c(G, dtype=np.float64),
        c(gb, dtype=np.float64),
        p,
        pref is not None,
        float(rcond),
    )
    saturated = tuple(int(i) for i in sat[: int(count)])
    return RowSolution(q, float(scale), saturated, int(it))


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
