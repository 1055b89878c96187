"""Kernels of the large projection operator and joint-limit law (Marey & Chaumette 2010).

Formulas and decisions: :mod:`redservo.redundancy.large_projection`, which wraps these
kernels. Projector modes: 0 ``"switched"``, 1 ``"norm"``, 2 ``"classical"``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.laws import F_ALPHA, I_PROJ, new_outputs, svd_outputs
from redservo.kernels.linalg import matvec, norm2, rmatvec, task_svd
from redservo.kernels.pack import Q_MAX, Q_MIN, RANGE

__all__ = [
    "joint_limit_term",
    "large_projection",
    "norm_projector",
    "sigmoid_gain",
    "switched_projector",
    "switching_value",
]

TINY_PII = 10.0 * 2.220446049250313e-16
I_DEGENERATE = 5


@kernel
def sigmoid_gain(x: float, x0: float, x1: float) -> float:
    """``1/(1 + exp(-12 (x - x0)/(x1 - x0) + 6))`` (0 when the exponential overflows)."""
    t = -12.0 * (x - x0) / (x1 - x0) + 6.0
    if t > 700.0:
        return 0.0
    return 1.0 / (1.0 + math.exp(t))


@kernel
def switching_value(e_norm: float, e0: float, e1: float) -> float:
    """λ(‖e‖): 0 below ``e0``, 1 above ``e1``, the sigmoid between (ICRA'10 eq. 24)."""
    if e_norm > e1:
        return 1.0
    if e_norm < e0:
        return 0.0
    return sigmoid_gain(e_norm, e0, e1)


@kernel
def norm_projector(J1: Any, e1: Any, smax: float, rcond: float) -> Any:
    """``(I - u u^T, degenerate)`` with ``u = J1^T e1 / ‖J1^T e1‖``; the identity when
    ``‖J1^T e1‖ <= rcond σ_max ‖e1‖`` (``smax`` = σ_max(J1))."""
    n = J1.shape[1]
    v = rmatvec(J1, e1)
    nv = norm2(v)
    P = np.eye(n)
    if nv == 0.0 or nv <= rcond * smax * norm2(e1):
        return P, True
    u = np.empty(n)
    for i in range(n):
        u[i] = v[i] / nv
    for i in range(n):
        for j in range(n):
            P[i, j] = P[i, j] - u[i] * u[j]
    return P, False


@kernel
def switched_projector(
    J1: Any,
    e1: Any,
    e0: float,
    e_switch: float,
    mode: int,
    V: Any,
    rank: int,
    smax: float,
    rcond: float,
) -> Any:
    """``(P_λ, rank, λ, degenerate)``: ``λ P_‖e‖ + (1 - λ)(I - J1⁺J1)`` (ICRA'10 eq. 24)."""
    n = J1.shape[1]
    if mode == 1:
        lam = 1.0
    elif mode == 2:
        lam = 0.0
    else:
        lam = switching_value(norm2(e1), e0, e_switch)
    N = np.zeros((n, n))  # I - J1⁺J1 = E E^T
    if lam < 1.0:
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for k in range(rank, n):
                    acc += V[i, k] * V[j, k]
                N[i, j] = acc
    if lam > 0.0:
        Pn, degenerate = norm_projector(J1, e1, smax, rcond)
        if lam < 1.0:
            P = np.empty((n, n))
            for i in range(n):
                for j in range(n):
                    P[i, j] = lam * Pn[i, j] + (1.0 - lam) * N[i, j]
        else:
            P = Pn
        return P, (n if degenerate else n - 1), lam, degenerate
    return N, n - rank, lam, False


@kernel
def joint_limit_term(
    q: Any,
    qdot1: Any,
    P: Any,
    lp: Any,
    rho: float,
    rho1: float,
    lambda_tune: float,
    robust: float,
) -> Any:
    """``(q̇2, activated)``: the IROS'10 term ``-Σ λ_l,i λ_sec,i P g_i`` (corrected ViSP
    variant, redundancy/large_projection.py); ``activated`` (n,) int8: 0 inactive, 1 active,
    2 active with ``1/|P_ii|`` filtered by the robust threshold."""
    n = q.shape[0]
    qdot2 = np.zeros(n)
    activated = np.zeros(n, dtype=np.int8)
    for i in range(n):
        rng = lp[RANGE, i]
        l0_min = lp[Q_MIN, i] + rho * rng
        l0_max = lp[Q_MAX, i] - rho * rng
        if q[i] > l0_max:
            sign = 1.0
            l0 = l0_max
            l1 = l0_max + rho * rho1 * rng
            beyond = q[i] >= l1
        elif q[i] < l0_min:
            sign = -1.0
            l0 = l0_min
            l1 = l0_min - rho * rho1 * rng
            beyond = q[i] <= l1
        else:
            continue
        activated[i] = 1
        lam_l = 1.0 if beyond else sigmoid_gain(q[i], l0, l1)
        p_ii = abs(sign * P[i, i])
        if p_ii < TINY_PII:
            b = 1.0
        else:
            inv = 1.0 / p_ii
            if p_ii < robust:
                inv = p_ii / (robust * robust)
                activated[i] = 2
            b = abs(qdot1[i]) * inv
            if not beyond:
                b = min(b, 1.0)
        gain = lam_l * (1.0 + lambda_tune) * b
        for k in range(n):
            qdot2[k] = qdot2[k] - gain * (sign * P[k, i])
    return qdot2, activated


@kernel
def large_projection(
    J1: Any,
    e1: Any,
    e: Any,
    q: Any,
    lp: Any,
    lam: float,
    sec: Any,
    has_sec: bool,
    e0: float,
    e_switch: float,
    mode: int,
    rho: float,
    rho1: float,
    lambda_tune: float,
    rcond: float,
    robust: float,
    p_robust: float,
) -> Any:
    """``q̇ = -λ J1⁺ e + P secondary + q̇2`` with ``P = P_λ`` (Marey & Chaumette 2010).

    Outputs: ``axes`` 1 on the activated joints, ``fout[F_ALPHA]`` λ(‖e1‖),
    ``iout[I_PROJ]`` the rank of P, ``iout[I_DEGENERATE]`` 1 when ``J1^T e1 ≈ 0``.
    """
    n = J1.shape[1]
    _, sigma, V, rank, pinv, filtered = task_svd(J1, rcond, robust)
    smax = sigma[0] if sigma.shape[0] > 0 else 0.0
    P, prank, lam_sw, degenerate = switched_projector(
        J1, e1, e0, e_switch, mode, V, rank, smax, rcond
    )
    qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
    pe = matvec(pinv, e)
    qdot1 = np.empty(n)
    for i in range(n):
        qdot1[i] = -lam * pe[i]
    if has_sec:
        ps = matvec(P, sec)
        for i in range(n):
            qdot1[i] = qdot1[i] + ps[i]
    qdot2, activated = joint_limit_term(q, qdot1, P, lp, rho, rho1, lambda_tune, p_robust)
    for i in range(n):
        qdot[i] = qdot1[i] + qdot2[i]
        axes[i] = activated[i]
    svd_outputs(sigma, rank, filtered, iout, fout)
    iout[I_PROJ] = prank
    iout[I_DEGENERATE] = 1 if degenerate else 0
    fout[F_ALPHA] = lam_sw
    return qdot, iout, fout, axes, axf, vec
