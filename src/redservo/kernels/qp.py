"""Kernels of the bounded least-squares law ``qp``: its bounds, and the steps before and after
its solver (the reduction and polish of the bounded least squares: :mod:`redservo.kernels.bls`).

Formulas and decisions: :mod:`redservo.redundancy.qp`, which wraps these kernels; the QP
solver runs between :func:`qp_prepare`/:func:`bls_reduce` and :func:`bls_expand`/
:func:`qp_finish`: by default the compiled one (:mod:`redservo.kernels.boxqp`, which also
chains them: the campaign loop's ``qp`` step), or a Python library on request.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.bls import ACTIVE_RTOL, bls_expand, bls_reduce
from redservo.kernels.linalg import matvec, null_project, task_svd
from redservo.kernels.pack import Q_MAX, Q_MIN, RANGE
from redservo.kernels.safety import apply_safety, command_box, exact_position_fix, intersect_boxes

__all__ = [
    "qp_complete",
    "qp_finish",
    "qp_prepare",
    "qp_setup",
    "qp_tail",
    "qp_velocity_bounds",
]


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
