"""A compiled solver for the reduced problem of the ``qp`` law: a strictly convex QP in a box.

::

    min_y  ½ yᵀ P y + cᵀ y    s.t.  lo <= y <= hi,      P symmetric positive definite

(``P = Jfᵀ Jf + ε I``, ``c = -(Jfᵀ rf + ε zf)``: :func:`redservo.kernels.bls.bls_reduce`).
:func:`box_qp` is the primal active-set method of Nocedal & Wright (*Numerical
Optimization*, 2nd ed., §16.5) specialised to bounds: the working set is a set of variables
held at one of their bounds; each iteration solves the equality-constrained problem on the
free variables by a Cholesky factorisation of ``P_FF``, then either steps to its solution
(and frees the variable with the most negative multiplier, or stops when none is) or stops
at the first bound in the way (which joins the working set). It starts from the
unconstrained minimiser clipped to the box, so the usual case (a few joints at a bound)
takes two or three iterations. A strictly convex QP has one minimiser: this is the point
daqp returns, to rounding (tests/test_boxqp.py checks 1e-9 on fuzzed problems).

Status codes: :data:`SOLVED`; :data:`INFEASIBLE` (a box with ``lo > hi``: the law then
takes its Python fallback and raises the flag ``solver-fallback``, as with daqp);
:data:`FAILED` (a non-finite number, ``P`` not positive definite to working precision, or
the iteration cap: also the fallback). No allocation beyond a few (k,) arrays and one
(k, k) factor; no BLAS call (small matrices, no thread start-up).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.bls import bls_reduce
from redservo.kernels.qp import qp_complete

__all__ = [
    "FAILED",
    "INFEASIBLE",
    "POLISH_RCOND",
    "SOLVED",
    "box_qp",
    "qp_solve",
    "qp_solve_reduced",
]

SOLVED, INFEASIBLE, FAILED = 1, -1, 0
"""Status codes of :func:`box_qp`."""
MULTIPLIER_RTOL = 1e-12
"""A bound's multiplier counts as negative below ``-1e-12 (1 + |c_i| + |(P y)_i|)`` (a
rounding-level tolerance that keeps the method from freeing and re-fixing a variable whose
multiplier is zero)."""
POLISH_RCOND = 1e-8
"""The ``rcond`` of the polish after the solve (``redundancy.linalg.DEFAULT_RCOND``, as the
law has always used there; a test checks that they agree)."""


@kernel
def _free_solve(P: Any, c: Any, y: Any, state: Any) -> Any:
    """``(z, ok)``: the minimiser over the free variables (``state == 0``) with the others
    held at ``y``: ``P_FF z_F = -(c_F + P_FW y_W)``, by Cholesky; ``z = y`` on the others.
    ``ok`` False when ``P_FF`` is not positive definite to working precision."""
    k = y.shape[0]
    idx = np.empty(k, dtype=np.int64)
    nf = 0
    for i in range(k):
        if state[i] == 0:
            idx[nf] = i
            nf += 1
    L = np.zeros((nf, nf))
    b = np.empty(nf)
    for a in range(nf):
        i = idx[a]
        acc = c[i]
        for j in range(k):
            if state[j] != 0:
                acc += P[i, j] * y[j]
        b[a] = -acc
        for bb in range(a + 1):
            s = P[i, idx[bb]]
            for t in range(bb):
                s -= L[a, t] * L[bb, t]
            if bb == a:
                if not s > 1e-300:  # also False for NaN
                    return y, False
                L[a, a] = np.sqrt(s)
            else:
                L[a, bb] = s / L[bb, bb]
    for a in range(nf):  # L w = b, then Lᵀ v = w
        s = b[a]
        for t in range(a):
            s -= L[a, t] * b[t]
        b[a] = s / L[a, a]
    for a in range(nf - 1, -1, -1):
        s = b[a]
        for t in range(a + 1, nf):
            s -= L[t, a] * b[t]
        b[a] = s / L[a, a]
    z = y.copy()
    for a in range(nf):
        z[idx[a]] = b[a]
    return z, True


@kernel
def _step_to(y: Any, z: Any, lo: Any, hi: Any, state: Any) -> int:
    """Move ``y`` toward ``z`` (free variables) as far as the box allows, in place; the
    variable stopped at a bound joins the working set (``state`` ∓1) and is returned, or -1
    when ``z`` is inside the box (then ``y = z``)."""
    k = y.shape[0]
    alpha = 1.0
    block = -1
    for i in range(k):
        if state[i] != 0:
            continue
        if z[i] < lo[i]:
            a = (lo[i] - y[i]) / (z[i] - y[i])
        elif z[i] > hi[i]:
            a = (hi[i] - y[i]) / (z[i] - y[i])
        else:
            continue
        if a < alpha:
            alpha = a
            block = i
    for i in range(k):
        if state[i] == 0:
            y[i] = z[i] if block < 0 else y[i] + alpha * (z[i] - y[i])
    if block >= 0:
        low = z[block] < lo[block]
        y[block] = lo[block] if low else hi[block]
        state[block] = -1 if low else 1
    return block


@kernel
def _release(P: Any, c: Any, y: Any, state: Any) -> int:
    """Free the held variable with the most negative multiplier (``g_i = (P y + c)_i`` at a
    lower bound, ``-g_i`` at an upper one) and return it; -1 when none is negative (the
    KKT conditions hold: ``y`` is optimal)."""
    k = y.shape[0]
    worst = 0.0
    out = -1
    for i in range(k):
        if state[i] == 0:
            continue
        g = c[i]
        py = 0.0
        for j in range(k):
            py += P[i, j] * y[j]
        g += py
        mult = g if state[i] < 0 else -g
        tol = MULTIPLIER_RTOL * (1.0 + abs(c[i]) + abs(py))
        if mult < -tol and mult < worst:
            worst = mult
            out = i
    if out >= 0:
        state[out] = 0
    return out


@kernel
def box_qp(P: Any, c: Any, lo: Any, hi: Any) -> Any:
    """``(y, status, iterations)``: the minimiser of ``½ yᵀ P y + cᵀ y`` over
    ``lo <= y <= hi`` (module docstring), all (k,) or (k, k) float64, any units."""
    k = c.shape[0]
    y = np.zeros(k)
    state = np.zeros(k, dtype=np.int64)  # -1 held at lo, +1 held at hi, 0 free
    for i in range(k):
        if not (np.isfinite(lo[i]) and np.isfinite(hi[i]) and np.isfinite(c[i])):
            return y, FAILED, 0
        if lo[i] > hi[i]:
            return y, INFEASIBLE, 0
    z, ok = _free_solve(P, c, y, state)  # the unconstrained minimiser, clipped
    if not ok:
        return y, FAILED, 0
    for i in range(k):
        y[i] = min(max(z[i], lo[i]), hi[i])
        if z[i] < lo[i]:
            state[i] = -1
        elif z[i] > hi[i]:
            state[i] = 1
    cap = 10 * k + 10
    for it in range(1, cap + 1):
        z, ok = _free_solve(P, c, y, state)
        if not ok:
            return y, FAILED, it
        if _step_to(y, z, lo, hi, state) < 0 and _release(P, c, y, state) < 0:
            for i in range(k):
                if not np.isfinite(y[i]):
                    return y, FAILED, it
            return y, SOLVED, it
    return y, FAILED, cap


@kernel
def qp_solve_reduced(
    J1: Any,
    xdot: Any,
    lo: Any,
    hi: Any,
    x: Any,
    free: Any,
    P: Any,
    c: Any,
    lof: Any,
    hif: Any,
    sec: Any,
    has_sec: bool,
    q: Any,
    dt: float,
    lp: Any,
) -> Any:
    """:func:`box_qp` on the reduced problem of :func:`redservo.kernels.qp.qp_setup`, then
    :func:`redservo.kernels.qp.qp_complete` (``sec`` the secondary command when ``has_sec``):
    ``(q̇, polished, active, residual, status)``; when ``status`` is not :data:`SOLVED` the
    first four are placeholders and the caller takes its fallback."""
    y, status, _ = box_qp(P, c, lof, hif)
    n = q.shape[0]
    if status != SOLVED:
        return x, False, np.zeros(n, dtype=np.bool_), -1.0, status
    fixed, polished, active, resid = qp_complete(
        J1, xdot, lo, hi, x, free, y, sec, has_sec, POLISH_RCOND, q, dt, lp
    )
    return fixed, polished, active, resid, status


@kernel
def qp_solve(
    J1: Any, xdot: Any, lo: Any, hi: Any, smax: float, eps: float, q: Any, dt: float, lp: Any
) -> Any:
    """The ``qp`` law's solve without a secondary command, from its bounds ``lo``, ``hi``
    (rad/s or m/s), ``ẋ`` and ``σ_max(J1)`` (:func:`redservo.kernels.qp.qp_prepare`):
    the relative ``eps`` made absolute, :func:`~redservo.kernels.bls.bls_reduce` and
    :func:`qp_solve_reduced`, as :func:`~redservo.kernels.qp.qp_setup` and the law do."""
    eps_abs = eps * smax * smax if smax > 0.0 else eps
    z = np.zeros(q.shape[0])
    x, free, _, _, _, lof, hif, P, c = bls_reduce(J1, xdot, lo, hi, z, eps_abs)
    return qp_solve_reduced(J1, xdot, lo, hi, x, free, P, c, lof, hif, z, False, q, dt, lp)
