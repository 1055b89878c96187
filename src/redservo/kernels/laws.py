"""Kernels of the null-space laws: classical, gradient projection (fixed and automatic gain).

Every law kernel returns the same tuple ``(q̇, iout, fout, axes, axf, vec)`` so that a
compiled caller (:func:`redservo.kernels.step.law_step`) can dispatch on a law id:

* ``q̇`` (n,): the raw command (before the safety layer), rad/s or m/s;
* ``iout`` (:data:`NI`,) int64 and ``fout`` (:data:`NF`,) float64: the diagnostics, at the
  indices ``I_*`` and ``F_*`` below (law-specific entries are documented per kernel);
* ``axes`` (n,) int64: per axis, the level (1, 2, ...) at which it is constrained, 0 if not;
* ``axf`` (n,) float64 and ``vec`` (any length): per-law numbers (γ, the gains a and b).

The Python laws (:mod:`redservo.redundancy`) turn them into :class:`~redservo.Diagnostics`.
Formulas, equation numbers and decisions are documented there; ``e`` below is the
effective error ``e1 + ∂e1/∂t / λ``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.joints import critical, gradient, in_band, margin
from redservo.kernels.linalg import matvec, norm2, null_project, task_svd
from redservo.kernels.pack import CENTER

__all__ = ["NF", "NI", "classical", "gpm", "gpm_auto", "new_outputs"]

NI = 16
NF = 16
I_RANK, I_FILTERED, I_PROJ, I_ITER, I_OVER = 0, 1, 2, 3, 4
"""Common integer outputs: task rank, filtered singular values, projector rank, iterations
or levels, overconstrained (0/1)."""
F_COND, F_ALPHA, F_SCALE = 0, 1, 2
"""Common float outputs: ``σ_max/σ_r`` when filtered, the gain α used, the task scale."""

# gpm-auto
I_K, I_CANDIDATES, I_ALPHA_CODE, I_DAMPED = 5, 6, 7, 8
F_ALPHA_RAW, F_DEN = 3, 4
ALPHA_OK, ALPHA_UNDEFINED, ALPHA_NEGATIVE, ALPHA_CAPPED = 0, 1, 2, 3

_DEN_TOL = 1e-10
ALPHA_FILTER = 1e-2


@kernel
def new_outputs(n: int, nvec: int) -> Any:
    """Zeroed ``(q̇, iout, fout, axes, axf, vec)``."""
    return (
        np.zeros(n),
        np.zeros(NI, dtype=np.int64),
        np.zeros(NF),
        np.zeros(n, dtype=np.int64),
        np.zeros(n),
        np.zeros(nvec),
    )


@kernel
def svd_outputs(sigma: Any, rank: int, filtered: int, iout: Any, fout: Any) -> None:
    """Store the rank, the filtered count and ``σ_max/σ_r`` (for the damped message)."""
    iout[I_RANK] = rank
    iout[I_FILTERED] = filtered
    if filtered > 0:
        fout[F_COND] = sigma[0] / sigma[rank - 1]


@kernel
def classical(
    J1: Any, e: Any, lam: float, sec: Any, has_sec: bool, rcond: float, robust: float
) -> Any:
    """``q̇ = -λ J1⁺ e + J1^⊥ secondary`` (CM01 eq. 2); ``iout[I_PROJ] = n - rank`` with a
    secondary command, else 0."""
    n = J1.shape[1]
    _, sigma, V, rank, pinv, filtered = task_svd(J1, rcond, robust)
    qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
    pe = matvec(pinv, e)
    for i in range(n):
        qdot[i] = -lam * pe[i]
    if has_sec:
        ns = null_project(V, rank, sec)
        for i in range(n):
            qdot[i] = qdot[i] + ns[i]
        iout[I_PROJ] = n - rank
    svd_outputs(sigma, rank, filtered, iout, fout)
    return qdot, iout, fout, axes, axf, vec


@kernel
def gpm(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    lam: float,
    sec: Any,
    has_sec: bool,
    alpha: float,
    rcond: float,
    robust: float,
) -> Any:
    """``q̇ = -λ (J1⁺e + α J1^⊥ e2) + J1^⊥ secondary`` (CM01 eqs. 1-6); ``axes`` marks the
    axes in the band (``e2_i ≠ 0``) when α > 0."""
    n = J1.shape[1]
    _, sigma, V, rank, pinv, filtered = task_svd(J1, rcond, robust)
    qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
    e2 = gradient(q, lp)
    pe = matvec(pinv, e)
    g = null_project(V, rank, e2)
    for i in range(n):
        qdot[i] = -lam * (pe[i] + alpha * g[i])
    if has_sec:
        ns = null_project(V, rank, sec)
        for i in range(n):
            qdot[i] += ns[i]
    if alpha > 0.0:
        for i in range(n):
            if e2[i] != 0.0:
                axes[i] = 1
    iout[I_PROJ] = n - rank
    fout[F_ALPHA] = alpha
    svd_outputs(sigma, rank, filtered, iout, fout)
    return qdot, iout, fout, axes, axf, vec


@kernel
def gpm_auto(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    alpha_max: float,
    current_rule: bool,
    rcond: float,
    robust: float,
    robust_alpha: bool,
) -> Any:
    """Gradient projection with α stopping the most critical axis (CM01 eqs. 7-9, eq. 9
    corrected: ``α = -w_k / (J1^⊥ e2)_k``).

    ``alpha_max = inf`` means no cap. Outputs: ``iout[I_K]`` the axis k (-1 if none),
    ``iout[I_CANDIDATES]`` the number of candidates (``axf`` = 1 on each), ``iout[I_ALPHA_CODE]``
    one of ``ALPHA_*``, ``iout[I_DAMPED]`` whether eq. 9 was filtered, ``fout[F_ALPHA_RAW]``
    the raw eq. 9 value, ``fout[F_DEN]`` ``|(J1^⊥ e2)_k|``; ``axes[k] = 1`` when α > 0.
    """
    n = J1.shape[1]
    _, sigma, V, rank, pinv, filtered = task_svd(J1, rcond, robust)
    qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
    w = matvec(pinv, e)
    if has_sec:
        ns = null_project(V, rank, sec)
        for i in range(n):
            w[i] = w[i] - ns[i] / lam
    e2 = gradient(q, lp)
    g = null_project(V, rank, e2)
    q_hat = np.empty(n)
    lam_dt = lam * dt
    for i in range(n):
        q_hat[i] = q[i] - lam_dt * w[i]  # eq. 8
    if current_rule:
        band = in_band(q, lp)
        cand = np.empty(n, dtype=np.bool_)
        for i in range(n):
            cand[i] = band[i] and (q_hat[i] - q[i]) * (q_hat[i] - lp[CENTER, i]) > 0.0
    else:
        cand = critical(q, q_hat, lp)
    marg = margin(q_hat, lp)
    k = -1
    count = 0
    for i in range(n):
        if cand[i]:
            axf[i] = 1.0
            count += 1
            if k < 0 or marg[i] < marg[k]:
                k = i
    alpha = 0.0
    iout[I_K] = k
    iout[I_CANDIDATES] = count
    if k >= 0:
        alpha = _alpha(k, w, g, e2, alpha_max, robust_alpha, iout, fout)
        if alpha > 0.0:
            axes[k] = 1
    for i in range(n):
        qdot[i] = -lam * (w[i] + alpha * g[i])
    iout[I_PROJ] = n - rank
    fout[F_ALPHA] = alpha
    svd_outputs(sigma, rank, filtered, iout, fout)
    return qdot, iout, fout, axes, axf, vec


@kernel
def _alpha(
    k: int,
    w: Any,
    g: Any,
    e2: Any,
    alpha_max: float,
    robust: bool,
    iout: Any,
    fout: Any,
) -> float:
    """Eq. 9 corrected with its degenerate cases (redundancy/gpm.py), codes in ``iout``."""
    den = g[k]
    emax = 0.0
    for i in range(e2.shape[0]):
        emax = max(emax, abs(e2[i]))
    fout[F_DEN] = abs(den)
    if abs(den) <= _DEN_TOL * emax:
        iout[I_ALPHA_CODE] = ALPHA_UNDEFINED
        return 0.0
    inv = 1.0 / den
    if robust:
        thr = ALPHA_FILTER * norm2(g)
        if abs(den) < thr:
            inv = abs(den) / (thr * thr) * np.sign(den)
            iout[I_DAMPED] = 1
    alpha = -w[k] * inv  # eq. 9, corrected
    fout[F_ALPHA_RAW] = alpha
    if alpha < 0.0:
        iout[I_ALPHA_CODE] = ALPHA_NEGATIVE
        return 0.0
    if alpha > alpha_max:
        iout[I_ALPHA_CODE] = ALPHA_CAPPED
        return alpha_max
    return alpha
