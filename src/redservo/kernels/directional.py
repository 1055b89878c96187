"""Kernels of MC05's directional redundancy (eqs. 9-23) and the WLN law (Chan & Dubey 1995).

Formulas, corrected equations and decisions: :mod:`redservo.redundancy.directional` and
:mod:`redservo.redundancy.wln`, which wrap these kernels.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.joints import gradient
from redservo.kernels.laws import I_PROJ, new_outputs, svd_outputs
from redservo.kernels.linalg import matvec, null_project, task_svd
from redservo.kernels.pack import Q_MAX, Q_MIN, RANGE

__all__ = [
    "directional",
    "inverse_weight",
    "projection",
    "weighted_null_add",
    "wln",
    "wln_gradient",
    "wln_weights",
]

I_FREED, I_CLIPPED, I_BLOCKED, I_ANY_Z = 5, 6, 7, 8
I_WRANK, I_WFILTERED = 5, 6
F_WCOND = 3


@kernel
def projection(
    U: Any, sigma: Any, V: Any, rank: int, e: Any, de: Any, z: Any, mu: float, want_P: bool
) -> Any:
    """MC05's non-linear projection of ``z`` (eqs. 18-22): ``(dq2, p, P)``.

    ``a = U_r^T (e + de)``, ``z̃ = V^T z``, ``y = σ z̃`` clamped between 0 and ``-2 μ a``
    (eq. 20, sign corrected), ``p_i = y_adm/y`` (1 where ``z̃_i = 0`` and for ``i >= r``),
    ``dq2 = V (p z̃)``; ``P = V diag(p) V^T`` (eq. 22 corrected) only if ``want_P``.
    """
    m = U.shape[0]
    n = V.shape[0]
    zt = np.zeros(n)
    for j in range(n):
        acc = 0.0
        for i in range(n):
            acc += V[i, j] * z[i]
        zt[j] = acc
    p = np.ones(n)
    for j in range(rank):
        a = 0.0
        for i in range(m):
            a += U[i, j] * (e[i] + de[i])
        y = sigma[j] * zt[j]
        far = -2.0 * mu * a
        y_adm = min(max(y, min(0.0, far)), max(0.0, far))
        if y != 0.0:
            p[j] = y_adm / y
    dq2 = np.zeros(n)
    for j in range(n):
        c = p[j] * zt[j]
        for i in range(n):
            dq2[i] += V[i, j] * c
    P = np.zeros((n, n) if want_P else (0, 0))
    if want_P:
        for i in range(n):
            for k in range(n):
                acc = 0.0
                for j in range(n):
                    acc += V[i, j] * p[j] * V[k, j]
                P[i, k] = acc
    return dq2, p, P


@kernel
def count_directions(V: Any, rank: int, z: Any, p: Any) -> Any:
    """Classify the task directions the secondary motion ``z`` (rad or m) moves along.

    ``V`` holds the right singular vectors of J1 (its first ``rank`` columns span the task
    directions) and ``p`` the diagonal of ``P̃_z`` (unitless, in [0, 1]). A direction with
    a non-zero component of ``z`` is freed (p = 1), clipped (0 < p < 1) or blocked (p = 0).

    Returns:
        ``(moving_used, freed, clipped, blocked)``: the counts; ``moving_used`` = freed +
        clipped.
    """
    n = V.shape[0]
    freed = 0
    clipped = 0
    blocked = 0
    moving_used = 0
    for j in range(rank):
        acc = 0.0
        for i in range(n):
            acc += V[i, j] * z[i]
        if acc != 0.0:
            if p[j] > 0.0:
                moving_used += 1
            if p[j] == 1.0:
                freed += 1
            elif p[j] > 0.0:
                clipped += 1
            else:
                blocked += 1
    return moving_used, freed, clipped, blocked


@kernel
def directional(
    J1: Any,
    e1: Any,
    e: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    lp: Any,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    kappa: float,
    use_jl: bool,
    mu: float,
    rcond: float,
    robust: float,
) -> Any:
    """``q̇ = -λ J1⁺ e + P_z z / dt``, ``z = dt (-κ e2 + secondary)`` (MC05 eqs. 10-23).

    ``e1`` is the measured error, ``e`` the effective one, ``ff`` the feed-forward
    ``∂e1/∂t``. Outputs: ``iout[I_PROJ]`` the directions the secondary command can use,
    ``iout[I_FREED/CLIPPED/BLOCKED]`` the task directions freed, clipped and blocked,
    ``iout[I_ANY_Z]`` whether z is non-zero; ``axf`` the diagonal p of ``P̃_z``.
    """
    m, n = J1.shape
    U, sigma, V, rank, pinv, filtered = task_svd(J1, rcond, robust)
    qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
    de = np.empty(m)
    e_start = np.empty(m)
    for i in range(m):
        de[i] = -lam * dt * e[i]
        e_start[i] = e1[i] + dt * ff[i] if has_ff else e1[i]
    dq1 = matvec(pinv, de)
    force = np.zeros(n)
    if use_jl:
        e2 = gradient(q, lp)
        for i in range(n):
            force[i] = force[i] + -kappa * e2[i]
    if has_sec:
        for i in range(n):
            force[i] = force[i] + sec[i]
    z = np.empty(n)
    any_z = False
    for i in range(n):
        z[i] = dt * force[i]
        any_z = any_z or z[i] != 0.0
    dq2, p, _ = projection(U, sigma, V, rank, e_start, de, z, mu, False)
    for i in range(n):
        qdot[i] = (dq1[i] + dq2[i]) / dt
        axf[i] = p[i]
    moving_used, freed, clipped, blocked = count_directions(V, rank, z, p)
    svd_outputs(sigma, rank, filtered, iout, fout)
    iout[I_PROJ] = (n - rank) + moving_used
    iout[I_FREED] = freed
    iout[I_CLIPPED] = clipped
    iout[I_BLOCKED] = blocked
    iout[I_ANY_Z] = 1 if any_z else 0
    return qdot, iout, fout, axes, axf, vec


@kernel
def wln_gradient(q: Any, lp: Any) -> Any:
    """(n,) ``∂H/∂q_i = Δq_i² (2q_i - q_max - q_min) / (4 (q_max - q_i)² (q_i - q_min)²)``.

    ``q`` is clipped to the limits; ±inf at a limit (never NaN there)."""
    n = q.shape[0]
    grad = np.empty(n)
    for i in range(n):
        qc = min(max(q[i], lp[Q_MIN, i]), lp[Q_MAX, i])
        d_hi = lp[Q_MAX, i] - qc
        d_lo = qc - lp[Q_MIN, i]
        num = lp[RANGE, i] ** 2 * (2.0 * qc - lp[Q_MAX, i] - lp[Q_MIN, i])
        prod = d_hi * d_lo
        den = 4.0 * (prod * prod)
        if den != 0.0:
            grad[i] = num / den
        elif num == 0.0:
            grad[i] = np.nan
        else:
            grad[i] = np.inf if num > 0.0 else -np.inf
    return grad


@kernel
def inverse_weight(grad: float, toward: bool) -> float:
    """``1/w_i``: ``1/(1 + |∂H/∂q_i|)`` toward a limit (0 at a limit), else 1."""
    return 1.0 / (1.0 + abs(grad)) if toward else 1.0


@kernel
def wln_weights(
    q: Any,
    lp: Any,
    qdot0: Any,
    history: bool,
    prev_abs: Any,
    has_prev: bool,
    report_grad: float,
    axes: Any,
    axf: Any,
) -> Any:
    """The WLN scaling ``d_i = sqrt(1/w_i)`` of each joint (Chan & Dubey 1995).

    A joint is penalized when it moves toward its limit: by the sign of ``∂H/∂q_i`` times the
    unweighted command ``qdot0``, or with ``history`` by ``|∂H/∂q_i|`` not decreasing since
    the previous call (``prev_abs``). Writes ``axf`` (``|∂H/∂q|``) and ``axes`` (1 on the
    penalized joints whose gradient exceeds ``report_grad``).
    """
    n = q.shape[0]
    grad = wln_gradient(q, lp)
    d = np.empty(n)
    for i in range(n):
        toward = np.sign(grad[i]) * qdot0[i] > 0.0
        cur = abs(grad[i])
        if history and has_prev and (np.isfinite(cur) or np.isfinite(prev_abs[i])):
            toward = cur - prev_abs[i] >= 0.0
        d[i] = np.sqrt(inverse_weight(grad[i], toward))
        axf[i] = cur
        if toward and cur > report_grad:
            axes[i] = 1
    return d


@kernel
def weighted_null_add(d: Any, wV: Any, wrank: int, sec: Any, qdot: Any) -> int:
    """Add ``D E_w (D E_w)ᵀ sec`` to ``qdot`` (``E_w`` the null-space basis of ``J1 D`` in
    ``wV`` past ``wrank``) and return the rank of ``D E_w``."""
    n = d.shape[0]
    k = n - wrank
    DE = np.empty((n, k))
    for i in range(n):
        for j in range(k):
            DE[i, j] = d[i] * wV[i, wrank + j]
    proj = np.zeros(n)
    for j in range(k):
        c = 0.0
        for i in range(n):
            c += DE[i, j] * sec[i]
        for i in range(n):
            proj[i] += DE[i, j] * c
    for i in range(n):
        qdot[i] = qdot[i] + proj[i]
    rank = 0
    if k > 0:
        _, s_de, _, _, _, _ = task_svd(DE, 0.0, 0.0)
        tol = s_de[0] * max(n, k) * 2.220446049250313e-16
        for i in range(s_de.shape[0]):
            if s_de[i] > tol:
                rank += 1
    return rank


@kernel
def _all_ones(d: Any) -> bool:
    """Whether every weight ``d_i`` is exactly 1 (no joint penalized: ``J1 D = J1``)."""
    for i in range(d.shape[0]):
        if d[i] != 1.0:
            return False
    return True


@kernel
def wln(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    lam: float,
    sec: Any,
    has_sec: bool,
    history: bool,
    prev_abs: Any,
    has_prev: bool,
    rcond: float,
    robust: float,
    report_grad: float,
) -> Any:
    """Weighted least norm ``q̇ = D (J1 D)⁺ ẋ``, ``D = W^{-1/2}`` (Chan & Dubey 1995).

    ``history`` uses the paper's rule ``|∂H/∂q_i|`` not decreasing since the previous call
    (``prev_abs``) where informative. Outputs: ``axes`` 1 on the penalized joints,
    ``axf`` ``|∂H/∂q|`` (for the next call), ``vec`` 1 on the joints blocked at a limit,
    ``iout[I_WRANK/I_WFILTERED]`` and ``fout[F_WCOND]`` for the weighted SVD,
    ``iout[I_PROJ]`` the rank of ``D E_w``.
    """
    m, n = J1.shape
    _, sigma, V, rank, pinv, filtered = task_svd(J1, rcond, robust)
    qdot, iout, fout, axes, axf, vec = new_outputs(n, n)
    xdot = np.empty(m)
    for i in range(m):
        xdot[i] = -lam * e[i]
    qdot0 = matvec(pinv, xdot)
    if has_sec:
        ns = null_project(V, rank, sec)
        for i in range(n):
            qdot0[i] = qdot0[i] + ns[i]
    d = wln_weights(q, lp, qdot0, history, prev_abs, has_prev, report_grad, axes, axf)
    JD = np.empty((m, n))
    for i in range(m):
        for j in range(n):
            JD[i, j] = J1[i, j] * d[j]
    if _all_ones(d):  # J1 D is J1 to the bit: its SVD is the one above, not a second
        wsig, wV, wrank, wpinv, wfiltered = sigma, V, rank, pinv, filtered
    else:
        _, wsig, wV, wrank, wpinv, wfiltered = task_svd(JD, rcond, robust)
    px = matvec(wpinv, xdot)
    for i in range(n):
        qdot[i] = d[i] * px[i]
    if has_sec:
        iout[I_PROJ] += weighted_null_add(d, wV, wrank, sec, qdot)
    smax = wsig[0] if wsig.shape[0] > 0 else 0.0
    for j in range(n):
        col = 0.0
        for i in range(m):
            col += JD[i, j] * JD[i, j]
        if np.sqrt(col) <= rcond * smax and d[j] < 1.0:
            vec[j] = 1.0
    svd_outputs(sigma, rank, filtered, iout, fout)
    iout[I_WRANK] = wrank
    iout[I_WFILTERED] = wfiltered
    if wfiltered > 0:
        fout[F_WCOND] = wsig[0] / wsig[wrank - 1]
    return qdot, iout, fout, axes, axf, vec
