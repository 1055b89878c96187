"""Kernels of the bounded least-squares law ``qp`` (its bounds, reduction and polish).

Formulas and decisions: :mod:`redservo.redundancy.qp`, which wraps these kernels; the QP
solver runs between :func:`qp_prepare`/:func:`bls_reduce` and :func:`bls_expand`/
:func:`qp_finish`: by default the compiled one (:mod:`redservo.kernels.boxqp`, which also
chains them: the campaign loop's ``qp`` step), or a Python library on request.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.linalg import matvec, null_project, task_svd
from redservo.kernels.pack import Q_MAX, Q_MIN, RANGE
from redservo.kernels.safety import apply_safety, command_box, exact_position_fix, intersect_boxes

__all__ = [
    "bls_expand",
    "bls_reduce",
    "polish",
    "qp_complete",
    "qp_finish",
    "qp_prepare",
    "qp_setup",
    "qp_tail",
    "qp_velocity_bounds",
]

ACTIVE_RTOL = 1e-8


@kernel
def qp_velocity_bounds(
    q: Any, lp: Any, dt: float, k_p: float, margin: float, v: Any, has_v: bool
) -> Any:
    """``(q̇_min, q̇_max, conflicts)`` of the QP (redundancy/qp.py); ``conflicts`` (n,)
    booleans: the push-back exceeds ``v_max`` and the joint is fixed at ``±v_max``."""
    n = q.shape[0]
    lo = np.empty(n)
    hi = np.empty(n)
    conflicts = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        band = margin * lp[RANGE, i]
        low = k_p * (lp[Q_MIN, i] + band - q[i]) / dt
        h = k_p * (lp[Q_MAX, i] - band - q[i]) / dt
        if has_v:
            push_up = low > v[i]
            push_down = h < -v[i]
            low = v[i] if push_up else max(low, -v[i])
            h = -v[i] if push_down else min(h, v[i])
            if push_down:
                low = -v[i]
            if push_up:
                h = v[i]
            conflicts[i] = push_up or push_down
        lo[i] = low
        hi[i] = h
    return lo, hi, conflicts


@kernel
def polish(J: Any, r: Any, z: Any, lo: Any, hi: Any, x: Any, rcond: float) -> Any:
    """``(y, ok)``: the exact minimum-``‖y - z‖`` least-squares solution on the active set of
    ``x`` (joints at a bound stay there); ``ok`` False when it leaves the bounds or increases
    the task residual (then ``y = x``)."""
    m, n = J.shape
    at_bound = np.empty(n, dtype=np.bool_)
    nf = 0
    for i in range(n):
        tol = ACTIVE_RTOL * (1.0 + max(abs(lo[i]), abs(hi[i])))
        at_bound[i] = x[i] - lo[i] <= tol or hi[i] - x[i] <= tol
        if not at_bound[i]:
            nf += 1
    if nf == 0:
        return x, False
    free = np.empty(nf, dtype=np.int64)
    k = 0
    for i in range(n):
        if not at_bound[i]:
            free[k] = i
            k += 1
    Jf = np.empty((m, nf))
    rf = r.copy()
    for i in range(m):
        for j in range(nf):
            Jf[i, j] = J[i, free[j]]
        acc = 0.0
        for j in range(n):
            if at_bound[j]:
                acc += J[i, j] * x[j]
        rf[i] = r[i] - acc
    pinv = task_svd(Jf, rcond, 0.0)[4]
    zf = np.empty(nf)
    for j in range(nf):
        zf[j] = z[free[j]]
    a = matvec(pinv, rf)
    c = matvec(pinv, matvec(Jf, zf))
    y = x.copy()
    for j in range(nf):
        y[free[j]] = a[j] + zf[j] - c[j]
    for i in range(n):
        tol = ACTIVE_RTOL * (1.0 + max(abs(lo[i]), abs(hi[i])))
        if not (np.isfinite(y[i]) and y[i] >= lo[i] - tol and y[i] <= hi[i] + tol):
            return x, False
        y[i] = min(max(y[i], lo[i]), hi[i])
    ry = matvec(J, y)
    rx = matvec(J, x)
    ny = 0.0
    nx = 0.0
    for i in range(m):
        ny += (ry[i] - r[i]) ** 2
        nx += (rx[i] - r[i]) ** 2
    if np.sqrt(ny) > np.sqrt(nx) * (1.0 + 1e-9) + 1e-15:
        return x, False
    return y, True


@kernel
def qp_prepare(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    dt: float,
    prev: Any,
    has_prev: bool,
    sec: Any,
    has_sec: bool,
    lam: float,
    k_p: float,
    margin: float,
    v_opt: Any,
    has_v_opt: bool,
    rcond: float,
    shield: bool = True,
) -> Any:
    """The ``qp`` law up to the solver: bounds ∩ safety box and the unconstrained optimum.

    ``shield``: whether the law's position shield is on (where the rate and position boxes
    miss, it decides which wins: :func:`~redservo.kernels.safety.command_box`).

    Returns:
        ``(q̇*, inside, lo, hi, conflicts, ẋ, rank, σ_max)``: the exact cascade solution
        without bounds ``J1⁺ ẋ + J1^⊥ secondary`` (``ẋ = -λ e``), whether it satisfies the
        bounds (then no solver is needed), the bounds, the joints whose push-back exceeds
        ``v_max``, ẋ, the rank of J1 and its largest singular value.
    """
    m, n = J1.shape
    lo_q, hi_q, conflicts = qp_velocity_bounds(q, lp, dt, k_p, margin, v_opt, has_v_opt)
    clo, chi = command_box(q, lp, has_v, has_a, dt, prev, has_prev, shield)
    lo, hi = intersect_boxes(lo_q, hi_q, clo, chi)
    xdot = np.empty(m)
    for i in range(m):
        xdot[i] = -lam * e[i]
    _, sigma, V, rank, pinv, _ = task_svd(J1, rcond, 0.0)
    qdot = matvec(pinv, xdot)
    if has_sec:
        ns = null_project(V, rank, sec)
        for i in range(n):
            qdot[i] = qdot[i] + ns[i]
    inside = True
    for i in range(n):
        if not (lo[i] <= qdot[i] and qdot[i] <= hi[i]):
            inside = False
    smax = sigma[0] if sigma.shape[0] > 0 else 0.0
    return qdot, inside, lo, hi, conflicts, xdot, rank, smax


@kernel
def qp_finish(J1: Any, xdot: Any, lo: Any, hi: Any, x: Any, q: Any, dt: float, lp: Any) -> Any:
    """After the solver: ``(q̇, active, residual)``, q̇ clipped and moved by the exact fix,
    the joints at a bound (n,) booleans and the relative task residual (-1 if ``ẋ = 0``)."""
    m, n = J1.shape
    active = np.empty(n, dtype=np.bool_)
    for i in range(n):
        tol = ACTIVE_RTOL * (1.0 + max(abs(lo[i]), abs(hi[i])))
        active[i] = x[i] - lo[i] <= tol or hi[i] - x[i] <= tol
    nx = 0.0
    for i in range(m):
        nx += xdot[i] * xdot[i]
    nx = np.sqrt(nx)
    resid = -1.0
    if nx > 0.0:
        r = matvec(J1, x)
        acc = 0.0
        for i in range(m):
            acc += (r[i] - xdot[i]) ** 2
        resid = np.sqrt(acc) / nx
    clipped = np.empty(n)
    for i in range(n):
        clipped[i] = min(max(x[i], lo[i]), hi[i])
    fixed, _ = exact_position_fix(q, clipped, dt, lp)
    return fixed, active, resid


@kernel
def bls_reduce(J: Any, r: Any, lo: Any, hi: Any, z: Any, eps: float) -> Any:
    """The bounded least squares ``min ‖J x - r‖² + eps ‖x - z‖²`` on its free variables.

    Variables with ``lo == hi`` (to 1e-12 relative) are fixed at the midpoint and removed.

    Returns:
        ``(x, free, Jf, rf, zf, lof, hif, P, c)``: x (n,) with the fixed values (0 on the
        free ones), the free indices, and the reduced problem, also as the QP
        ``min ½ y^T P y + c^T y`` with ``P = Jf^T Jf + eps I``, ``c = -(Jf^T rf + eps zf)``.
    """
    m, n = J.shape
    x = np.zeros(n)
    fixed = np.empty(n, dtype=np.bool_)
    k = 0
    for i in range(n):
        fixed[i] = hi[i] - lo[i] <= 1e-12 * (1.0 + abs(hi[i]))
        if fixed[i]:
            x[i] = 0.5 * (lo[i] + hi[i])
        else:
            k += 1
    free = np.empty(k, dtype=np.int64)
    j = 0
    for i in range(n):
        if not fixed[i]:
            free[j] = i
            j += 1
    Jf = np.empty((m, k))
    rf = np.empty(m)
    for i in range(m):
        acc = 0.0
        for c_ in range(n):
            if fixed[c_]:
                acc += J[i, c_] * x[c_]
        rf[i] = r[i] - acc
        for c_ in range(k):
            Jf[i, c_] = J[i, free[c_]]
    zf = np.empty(k)
    lof = np.empty(k)
    hif = np.empty(k)
    for c_ in range(k):
        zf[c_] = z[free[c_]]
        lof[c_] = lo[free[c_]]
        hif[c_] = hi[free[c_]]
    P = np.empty((k, k))
    c = np.empty(k)
    for a in range(k):
        for b in range(k):
            acc = 0.0
            for i in range(m):
                acc += Jf[i, a] * Jf[i, b]
            P[a, b] = acc + eps if a == b else acc
        acc = 0.0
        for i in range(m):
            acc += Jf[i, a] * rf[i]
        c[a] = -(acc + eps * zf[a])
    return x, free, Jf, rf, zf, lof, hif, P, c


@kernel
def bls_expand(
    J: Any, r: Any, z: Any, lo: Any, hi: Any, x: Any, free: Any, xf: Any, rcond: float
) -> Any:
    """``(x, polished)``: the free values put back, clipped to the bounds, then
    :func:`polish` applied when it is valid."""
    out = x.copy()
    for j in range(free.shape[0]):
        out[free[j]] = xf[j]
    for i in range(out.shape[0]):
        out[i] = min(max(out[i], lo[i]), hi[i])
    y, ok = polish(J, r, z, lo, hi, out, rcond)
    return (y, True) if ok else (out, False)


@kernel
def qp_setup(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    dt: float,
    prev: Any,
    has_prev: bool,
    sec: Any,
    has_sec: bool,
    lam: float,
    k_p: float,
    margin: float,
    v_opt: Any,
    has_v_opt: bool,
    rcond: float,
    eps: float,
    shield: bool = True,
) -> Any:
    """:func:`qp_prepare` then :func:`bls_reduce` in one call (the law's fast path).

    ``eps`` is relative: the regularization is ``eps σ_max(J1)²`` (``eps`` if J1 = 0).
    ``shield`` as in :func:`qp_prepare`.

    Returns:
        ``(q̇*, inside, lo, hi, conflicts, ẋ, rank, ε, x, free, P, c, lof, hif)``: the
        outputs of :func:`qp_prepare`, the absolute ε, and the QP of :func:`bls_reduce`
        (``z`` = the secondary command).
    """
    qdot, inside, lo, hi, conflicts, xdot, rank, smax = qp_prepare(
        J1,
        e,
        q,
        lp,
        has_v,
        has_a,
        dt,
        prev,
        has_prev,
        sec,
        has_sec,
        lam,
        k_p,
        margin,
        v_opt,
        has_v_opt,
        rcond,
        shield,
    )
    eps_abs = eps * smax * smax if smax > 0.0 else eps
    z = sec if has_sec else np.zeros(q.shape[0])
    x, free, _, _, _, lof, hif, P, c = bls_reduce(J1, xdot, lo, hi, z, eps_abs)
    return qdot, inside, lo, hi, conflicts, xdot, rank, eps_abs, x, free, P, c, lof, hif


@kernel
def qp_complete(
    J1: Any,
    xdot: Any,
    lo: Any,
    hi: Any,
    x: Any,
    free: Any,
    xf: Any,
    sec: Any,
    has_sec: bool,
    rcond: float,
    q: Any,
    dt: float,
    lp: Any,
) -> Any:
    """:func:`bls_expand` then :func:`qp_finish`: ``(q̇, polished, active, residual)``."""
    z = sec if has_sec else np.zeros(q.shape[0])
    x2, polished = bls_expand(J1, xdot, z, lo, hi, x, free, xf, rcond)
    fixed, active, resid = qp_finish(J1, xdot, lo, hi, x2, q, dt, lp)
    return fixed, polished, active, resid


@kernel
def qp_tail(
    J1: Any,
    xdot: Any,
    lo: Any,
    hi: Any,
    inside: bool,
    qdot_star: Any,
    x: Any,
    free: Any,
    xf: Any,
    sec: Any,
    has_sec: bool,
    rcond: float,
    q: Any,
    dt: float,
    lp: Any,
    has_v: bool,
    has_a: bool,
    prev: Any,
    has_prev: bool,
    shield: bool,
) -> Any:
    """After the solver: :func:`qp_complete` (or the unconstrained optimum when ``inside``)
    and the safety layer; the safe command (n,) only (the compiled ``qp`` step)."""
    if inside:
        fixed = qp_finish(J1, xdot, lo, hi, qdot_star, q, dt, lp)[0]
    else:
        fixed = qp_complete(J1, xdot, lo, hi, x, free, xf, sec, has_sec, rcond, q, dt, lp)[0]
    return apply_safety(fixed, q, lp, has_v, has_a, dt, prev, has_prev, shield, fixed, False)[0]
