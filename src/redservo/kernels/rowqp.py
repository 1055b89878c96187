"""A compiled dense QP with general inequality rows and a box: the ``qp`` law's distance rows.

::

    min_y  ½ yᵀ H y + fᵀ y    s.t.  lo <= y <= hi,   G y >= b,      H symmetric positive definite

:func:`dense_qp` is the dual active-set method of Goldfarb & Idnani (*Math. Programming*
27, 1983), the method of quadprog: it starts from the unconstrained minimiser
``y = -H⁻¹ f`` and adds the most violated constraint (a bound ``y_i >= lo_i``,
``-y_i >= -hi_i`` or a row ``G_k y >= b_k``) at each outer iteration, dropping active
constraints whose multiplier would turn negative on the way (partial steps); every
iterate is the minimiser over its active set, the dual objective rises at each full step,
so no active set comes back and the method ends after finitely many steps, with the
minimiser or with a constraint no step can satisfy (the problem is infeasible). The
active set's normals are kept as ``L⁻¹ Nᵀ = Q R`` (``H = L Lᵀ``, Gram-Schmidt with
reorthogonalisation, rebuilt after a drop); a constraint whose normal is dependent on the
active ones (``‖(I − QQᵀ) L⁻¹ n‖`` at rounding level) takes a dual-only step, as in the
paper. A strictly convex QP has one minimiser: this is the point daqp returns, to rounding
(tests/test_rowqp.py: 1e-9 on fuzzed problems, degenerate and infeasible ones included).

Status codes: :data:`SOLVED`, :data:`INFEASIBLE` (no point meets every constraint, or a box
with ``lo > hi``), :data:`FAILED` (a non-finite number, ``H`` not positive definite to
working precision, or the iteration cap ``3 (2n + r) + 10``); never NaN in a solved ``y``.
Loops only, no BLAS call: the same bits compiled or not, and on both of the law's paths.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.linalg import norm2

__all__ = ["FAILED", "INFEASIBLE", "SOLVED", "dense_qp", "qp_rows"]

SOLVED, INFEASIBLE, FAILED = 1, -1, 0
"""Status codes of :func:`dense_qp` (those of :mod:`redservo.kernels.boxqp`)."""
FEAS_RTOL = 1e-12
"""A constraint counts as violated below ``-1e-12 (1 + |bound| + |n|·|y|)`` (m/s for a row)."""
DEP_RTOL = 1e-12
"""A normal is dependent on the active ones when its part outside them is below ``1e-12``
of its length (in the metric of ``H``)."""


@kernel
def _cholesky(H: Any) -> Any:
    """``(L, ok)``: ``H = L Lᵀ``; ``ok`` False when ``H`` is not positive definite."""
    n = H.shape[0]
    L = np.zeros((n, n))
    for a in range(n):
        for c in range(a + 1):
            s = H[a, c]
            for t in range(c):
                s -= L[a, t] * L[c, t]
            if c == a:
                if not s > 1e-300:  # also False for NaN
                    return L, False
                L[a, a] = np.sqrt(s)
            else:
                L[a, c] = s / L[c, c]
    return L, True


@kernel
def _lsolve(L: Any, v: Any, transposed: bool) -> Any:
    """``L⁻¹ v`` (or ``L⁻ᵀ v`` when ``transposed``), L lower triangular."""
    n = v.shape[0]
    w = v.copy()
    if not transposed:
        for a in range(n):
            s = w[a]
            for t in range(a):
                s -= L[a, t] * w[t]
            w[a] = s / L[a, a]
    else:
        for a in range(n - 1, -1, -1):
            s = w[a]
            for t in range(a + 1, n):
                s -= L[t, a] * w[t]
            w[a] = s / L[a, a]
    return w


@kernel
def _project(Q: Any, k: int, w: Any) -> Any:
    """``(d, c)``: ``d = w − Q c`` orthogonal to ``Q[:, :k]``, ``c = Qᵀ w`` (two passes)."""
    n = w.shape[0]
    d = w.copy()
    c = np.zeros(k)
    for _ in range(2):
        for j in range(k):
            acc = 0.0
            for i in range(n):
                acc += Q[i, j] * d[i]
            c[j] += acc
            for i in range(n):
                d[i] -= acc * Q[i, j]
    return d, c


@kernel
def _refactor(W: Any, active: Any, k: int, Q: Any, R: Any) -> None:
    """``Q R`` of the active normals ``W[active[:k]]`` (columns), in place."""
    for j in range(k):
        d, c = _project(Q, j, W[active[j]])
        nd = norm2(d)
        for i in range(j):
            R[i, j] = c[i]
        R[j, j] = nd
        for i in range(d.shape[0]):
            Q[i, j] = d[i] / nd


@kernel
def _constraints(lo: Any, hi: Any, G: Any, b: Any) -> Any:
    """``(C, cb)``: every constraint as ``C_i y >= cb_i`` (bounds, then rows)."""
    n, r = lo.shape[0], b.shape[0]
    C = np.zeros((2 * n + r, n))
    cb = np.empty(2 * n + r)
    for i in range(n):
        C[2 * i, i], cb[2 * i] = 1.0, lo[i]
        C[2 * i + 1, i], cb[2 * i + 1] = -1.0, -hi[i]
    for k in range(r):
        C[2 * n + k, :] = G[k]
        cb[2 * n + k] = b[k]
    return C, cb


@kernel
def _most_violated(C: Any, cb: Any, y: Any, is_active: Any) -> Any:
    """``(p, s_p)``: the constraint violated most (-1: none beyond the tolerance)."""
    p, worst = -1, 0.0
    for i in range(C.shape[0]):
        if is_active[i]:
            continue
        s, mag = -cb[i], abs(cb[i])
        for j in range(y.shape[0]):
            s += C[i, j] * y[j]
            mag += abs(C[i, j] * y[j])
        if s < -FEAS_RTOL * (1.0 + mag) and s < worst:
            p, worst = i, s
    return p, worst


@kernel
def _direction(L: Any, Q: Any, R: Any, k: int, w: Any) -> Any:
    """``(z, r, dd)`` for the normal ``w = L⁻¹ n``: the primal step ``z = L⁻ᵀ (I − QQᵀ) w``,
    the dual step ``r = R⁻¹ Qᵀ w`` and ``‖(I − QQᵀ) w‖²`` (0: dependent normal)."""
    d, c = _project(Q, k, w)
    r = np.zeros(k)
    for a in range(k - 1, -1, -1):
        s = c[a]
        for t in range(a + 1, k):
            s -= R[a, t] * r[t]
        r[a] = s / R[a, a]
    nd = norm2(d)
    if not nd > DEP_RTOL * norm2(w):
        return np.zeros(w.shape[0]), r, 0.0
    return _lsolve(L, d, True), r, nd * nd


@kernel
def _add_or_drop(p: int, s: float, y: Any, u: Any, up: Any, act: Any, k: int, dirs: Any) -> Any:
    """One step of the inner loop for constraint ``p`` (``s`` its slack, < 0): ``(k, added,
    infeasible)``; ``y``, the active multipliers ``u``, ``up[0]`` (``p``'s) and ``act``
    updated in place."""
    z, r, dd = dirs
    t1, drop = np.inf, -1
    for j in range(k):
        if r[j] > 0.0 and u[j] / r[j] < t1:
            t1, drop = u[j] / r[j], j
    t2 = -s / dd if dd > 0.0 else np.inf
    t = min(t1, t2)
    if not np.isfinite(t):
        return k, False, True
    for j in range(k):
        u[j] -= t * r[j]
    up[0] += t
    if dd > 0.0:
        for i in range(y.shape[0]):
            y[i] += t * z[i]
    if t2 <= t1:
        act[k], u[k] = p, up[0]
        return k + 1, True, False
    for j in range(drop, k - 1):
        act[j], u[j] = act[j + 1], u[j + 1]
    return k - 1, False, False


@kernel
def dense_qp(H: Any, f: Any, lo: Any, hi: Any, G: Any, b: Any) -> Any:
    """``(y, status, iterations)``: the minimiser of ``½ yᵀ H y + fᵀ y`` over
    ``lo <= y <= hi`` and ``G y >= b`` (module docstring); H (n, n), G (r, n), any units."""
    n = f.shape[0]
    y = np.zeros(n)
    for i in range(n):
        if not (np.isfinite(lo[i]) and np.isfinite(hi[i]) and np.isfinite(f[i])):
            return y, FAILED, 0
        if lo[i] > hi[i]:
            return y, INFEASIBLE, 0
    if not (np.all(np.isfinite(G)) and np.all(np.isfinite(b))):
        return y, FAILED, 0
    L, ok = _cholesky(H)
    if not ok:
        return y, FAILED, 0
    g = _lsolve(L, f, False)
    y = -_lsolve(L, g, True)
    C, cb = _constraints(lo, hi, G, b)
    W = np.empty_like(C)
    for i in range(C.shape[0]):
        W[i] = _lsolve(L, C[i], False)
    act, u = np.zeros(n, dtype=np.int64), np.zeros(n)
    Q, R = np.zeros((n, n)), np.zeros((n, n))
    is_active = np.zeros(C.shape[0], dtype=np.bool_)
    k, it, cap = 0, 0, 3 * C.shape[0] + 10
    p, s = _most_violated(C, cb, y, is_active)
    up = np.zeros(1)
    while p >= 0:
        it += 1
        if it > cap:
            return y, FAILED, cap
        z, r, dd = _direction(L, Q, R, k, W[p])
        if k == n:  # n independent normals span every direction: dependent (rounding)
            z, dd = np.zeros(n), 0.0
        k, added, infeasible = _add_or_drop(p, s, y, u, up, act, k, (z, r, dd))
        if infeasible:
            return y, INFEASIBLE, it
        is_active[:] = False
        for j in range(k):
            is_active[act[j]] = True
        _refactor(W, act, k, Q, R)
        if added:  # y again from its active set (no drift from the steps' sum)
            up[0] = 0.0
            _on_active_set(L, g, Q, R, cb, act, k, y)
            p, s = _most_violated(C, cb, y, is_active)
        else:
            s = _slack(C[p], cb[p], y)
    ok = np.all(np.isfinite(y))
    return y, (SOLVED if ok else FAILED), it


@kernel
def _on_active_set(L: Any, g: Any, Q: Any, R: Any, cb: Any, act: Any, k: int, y: Any) -> None:
    """``y`` (in place) the minimiser with the active constraints as equalities:
    ``v = −(I − QQᵀ) g + Q R⁻ᵀ cb_A``, ``y = L⁻ᵀ v`` (``g = L⁻¹ f``)."""
    h = np.empty(k)
    for a in range(k):  # Rᵀ h = cb_A
        s = cb[act[a]]
        for t in range(a):
            s -= R[t, a] * h[t]
        h[a] = s / R[a, a]
    v, _ = _project(Q, k, g)
    for i in range(v.shape[0]):
        acc = -v[i]
        for a in range(k):
            acc += Q[i, a] * h[a]
        v[i] = acc
    y[:] = _lsolve(L, v, True)


@kernel
def _slack(c: Any, cb: float, y: Any) -> float:
    """``c·y − cb``."""
    s = -cb
    for j in range(y.shape[0]):
        s += c[j] * y[j]
    return s


@kernel
def qp_rows(
    J1: Any, xdot: Any, lo: Any, hi: Any, eps: float, sec: Any, has_sec: bool, G: Any, b: Any
) -> Any:
    """The ``qp`` law's problem with its distance rows (redundancy/distance_rows.py):
    ``min ‖J1 q̇ − ẋ‖² + ε ‖q̇ − sec‖²`` s.t. ``lo <= q̇ <= hi`` (rad/s or m/s) and
    ``G q̇ >= b`` (m/s), then, when that is infeasible, with the rows relaxed to "never
    closer" (``b`` capped at 0). ``(q̇, status, relaxed)``: status :data:`SOLVED` (q̇ the
    minimiser; ``relaxed`` whether the relaxed rows were solved), :data:`INFEASIBLE` (both
    problems) or :data:`FAILED` (the solver's cap or a numerical failure)."""
    m, n = J1.shape
    H = np.empty((n, n))
    f = np.empty(n)
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for a in range(m):
                acc += J1[a, i] * J1[a, j]
            H[i, j] = acc + (eps if i == j else 0.0)
        acc = 0.0
        for a in range(m):
            acc += J1[a, i] * xdot[a]
        f[i] = -acc - (eps * sec[i] if has_sec else 0.0)
    y, status, _ = dense_qp(H, f, lo, hi, G, b)
    if status != INFEASIBLE:
        return y, status, False
    y, status, _ = dense_qp(H, f, lo, hi, G, np.minimum(b, 0.0))
    return y, status, True
