"""Velocity-damper rows in the compiled campaign loop: built as the object path builds them.

With a run's collision avoidance on, ``qp`` and ``sns`` solve with the rows ``J_k q̇ ≥ b_k``
of the pairs within ``d_influence`` (:mod:`redservo.redundancy.distance_rows`). At every
iteration of :func:`redservo.campaign.loop_kernel.closed_loop` for these laws:

1. :func:`damper_rows` builds the rows from the distances the loop measured at ``q``
   (:func:`~redservo.kernels.loop_avoid.collide_check`: the object path's kernel, so the same
   ``d`` and ``J_d`` to the bit; every pair within ``d_influence`` is computed), by the very
   operations of :func:`~redservo.redundancy.distance_rows.distance_rows`, in pair order:
   ``b_k = −ξ (d_k − d_s)/(d_i − d_s) − ∂d_k/∂t``. The compiled geometry has static obstacles
   only (:func:`redservo.collision.pack.geometry_reason`), whose ``∂d_k/∂t`` the object path
   sets to 0; the subtraction is kept, and exact.
2. The law's compiled step solves with them, with the kernels the law objects call too
   (so the two paths give the same command to the bit): :func:`rows_met` decides whether a
   command meets every row (by the object path's tolerance,
   :data:`~redservo.kernels.row_tolerance.ROW_TOL`); ``qp`` solves its QP with the rows by
   :func:`redservo.kernels.rowqp.qp_rows` when its unconstrained optimum does not meet
   them, ``sns`` runs Algorithm 1 over the joints and the rows
   (:mod:`redservo.kernels.sns_rows`) when its command breaks one. A step is handed back to
   Python (:func:`hand_back`, the law called with these rows) only when the law's solver is
   a Python library (``qp`` with ``solver = "daqp"`` and the like).

Units: m, m/s, rad, s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.qp import qp_finish
from redservo.kernels.row_tolerance import ROW_TOL
from redservo.kernels.rowqp import FAILED, SOLVED, qp_rows

__all__ = ["I_ROWS", "damper_rows", "hand_back", "qp_row_step", "rows_met"]

I_ROWS = 6
"""The index in the collision pack's ``iopt`` (:mod:`redservo.kernels.loop_avoid`) of the
flag: the law solves with the damper rows."""


@kernel
def damper_rows(d: Any, J: Any, coll: Any) -> Any:
    """``(G (r, n), b (r,), pairs (r,) int64)``: the rows of the pairs closer than ``d_i``
    in pair order (module docstring), none unless the collision pack asks for rows."""
    fopt, iopt = coll[3], coll[4]
    n = J.shape[1]
    if not (coll[0] and iopt[I_ROWS] != 0):
        return np.zeros((0, n)), np.zeros(0), np.zeros(0, dtype=np.int64)
    d_safe, d_i, xi = fopt[0], fopt[1], fopt[2]
    r = 0
    for p in range(d.shape[0]):
        if d[p] < d_i:
            r += 1
    G, b, pairs = np.empty((r, n)), np.empty(r), np.empty(r, dtype=np.int64)
    k = 0
    for p in range(d.shape[0]):
        if d[p] < d_i:
            ramp = xi * (d[p] - d_safe) / (d_i - d_safe)
            G[k, :] = J[p]
            b[k] = -ramp - 0.0  # − ∂d/∂t: 0 for the compiled geometry's static obstacles
            pairs[k] = p
            k += 1
    return G, b, pairs


@kernel
def rows_met(G: Any, b: Any, qd: Any) -> bool:
    """Whether ``qd`` (n,) meets every row, ``G_k q̇ ≥ b_k − ROW_TOL`` (m/s); the product
    written out (no BLAS), so the law objects, which call this very kernel
    (:func:`redservo.redundancy.distance_rows.rows_hold`), and the loop decide alike."""
    for k in range(G.shape[0]):
        g = 0.0
        for j in range(G.shape[1]):
            g += G[k, j] * qd[j]
        if not g >= b[k] - ROW_TOL:
            return False
    return True


@kernel
def qp_row_step(
    J1: Any,
    xdot: Any,
    lo: Any,
    hi: Any,
    eps: float,
    z: Any,
    has_sec: bool,
    G: Any,
    b: Any,
    inside: bool,
    x: Any,
    q: Any,
    dt: float,
    lp: Any,
) -> Any:
    """The ``qp`` law's rows (``BoundedLeastSquares._rows``, redundancy/qp.py): unless there
    is none or the unconstrained optimum ``x`` is ``inside`` the bounds and meets them,
    :func:`~redservo.kernels.rowqp.qp_rows` then ``qp_finish``. ``(q̇, residual, solved,
    failed)``: ``solved`` False leaves the step to the law's box solve (no row, or the rows
    dropped: infeasible even relaxed, or ``failed``, which the law flags)."""
    if b.shape[0] == 0 or (inside and rows_met(G, b, x)):
        return x, -1.0, False, False
    y, status, _ = qp_rows(J1, xdot, lo, hi, eps, z, has_sec, G, b)
    if status != SOLVED:
        return x, -1.0, False, status == FAILED
    fixed, _, resid = qp_finish(J1, xdot, lo, hi, y, q, dt, lp)
    return fixed, resid, True, False


@kernel
def hand_back(
    solve: Any, J1: Any, e1: Any, ff: Any, has_ff: bool, sec: Any, rows: Any, it: int
) -> None:
    """Put what the law needs into ``solve`` (:mod:`redservo.campaign.loop_kernel`): the
    step's ``J1``, ``e1``, feed-forward, secondary and damper ``rows = (G, b, pairs)``."""
    pJ, pe, _, pend, pf, ps, pG, pb, pp = solve
    G, b, pairs = rows
    r = b.shape[0]
    pJ[:, :] = J1
    pe[:] = e1
    pf[:] = ff
    pend[2], pend[3], pend[4] = it, 1 if has_ff else 0, r
    pend[5] = 1 if sec.shape[0] > 0 else 0
    if sec.shape[0] > 0:
        ps[:] = sec
    pG[:r, :] = G
    pb[:r] = b
    pp[:r] = pairs
