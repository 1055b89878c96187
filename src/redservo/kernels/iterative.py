"""Kernels of CM01's iterative null-space scheme (§III, eqs. 10-21).

The algorithm, its decisions and the corrected equations are documented in
:mod:`redservo.redundancy.iterative`, which wraps these kernels. ``lp`` is the packed
limits (:func:`redservo.redundancy.packs.limits_pack`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.joints import critical, gamma, gradient
from redservo.kernels.lapack import gesvd
from redservo.kernels.laws import I_ITER, I_OVER, I_PROJ, new_outputs, svd_outputs
from redservo.kernels.linalg import matvec, null_project, task_svd

__all__ = ["constrain", "iterate_null_space", "iterative"]

RESIDUAL_TOL = 1e-9
"""A least-squares residual above this fraction of the right-hand side means 'not met'."""
I_NCON, I_NA = 5, 6
F_MIN_SIGMA = 3


@kernel
def constrain(N: Any, K: Any, rhs: Any, tol: float, robust: float) -> Any:
    """Minimum-norm motion ``Δ = N c`` with ``Δ_K = rhs``; return ``(Δ, N Z, met, σ_min)``.

    ``Z`` is an orthonormal basis of ``Ker N_K`` (one ``dgesvd`` of the p x f block);
    singular values at or below ``tol`` count as zero, those below ``robust`` are inverted
    with the bounded filter.
    """
    n, f = N.shape
    p = K.shape[0]
    none_left = True
    for i in range(p):
        if rhs[i] != 0.0:
            none_left = False
    if f == 0:  # no free direction left
        return np.zeros(n), N, none_left, np.inf
    A = np.empty((p, f))
    for i in range(p):
        for j in range(f):
            A[i, j] = N[K[i], j]
    U, s, V, info = gesvd(A)
    if info != 0:  # LAPACK did not converge (never seen on finite input): do nothing
        return np.zeros(n), N, none_left, np.inf
    r = 0
    for i in range(s.shape[0]):
        if s[i] > tol:
            r += 1
    coef = np.empty(r)
    for l in range(r):
        ur = 0.0
        for i in range(p):
            ur += U[i, l] * rhs[i]
        if robust > 0.0 and s[l] < robust:
            inv = s[l] / (robust * robust)
        else:
            inv = 1.0 / s[l]
        coef[l] = ur * inv
    c = np.zeros(f)
    for j in range(f):
        acc = 0.0
        for l in range(r):
            acc += V[j, l] * coef[l]
        c[j] = acc
    met = r == p
    if not met:
        worst = 0.0
        big = 0.0
        for l in range(r, p):
            ur = 0.0
            for i in range(p):
                ur += U[i, l] * rhs[i]
            worst = max(worst, abs(ur))
        for i in range(p):
            big = max(big, abs(rhs[i]))
        met = worst <= RESIDUAL_TOL * big
    step = matvec(N, c)
    Nz = np.empty((n, f - r))
    for i in range(n):
        for j in range(f - r):
            acc = 0.0
            for l in range(f):
                acc += N[i, l] * V[l, r + j]
            Nz[i, j] = acc
    return step, Nz, met, s[r - 1] if r > 0 else np.inf


@kernel
def level_constraints(q: Any, q_hat: Any, lp: Any, free: Any, v: Any, smooth: bool) -> Any:
    """The constraints of one level of CM01's scheme (eqs. 11/16, 15/18/21).

    ``q`` (rad or m) is the configuration and ``q_hat = q - λ·dt·v`` its prediction with
    the level's control ``v`` (rad or m per ``λ·dt``); the axes critical at ``q_hat`` and
    still ``free`` are constrained.

    Returns:
        ``(K, g, rhs)``: the constrained axes in order, their γ (unitless; 1 unless
        ``smooth``) and ``-γ v_K``. All empty when no axis is constrained.
    """
    n = q.shape[0]
    crit = critical(q, q_hat, lp)
    count = 0
    for i in range(n):
        if crit[i] and free[i]:
            count += 1
    K = np.empty(count, dtype=np.int64)
    rhs = np.empty(count)
    g = np.empty(count)
    if count == 0:
        return K, g, rhs
    j = 0
    for i in range(n):
        if crit[i] and free[i]:
            K[j] = i
            j += 1
    gall = gamma(q_hat, lp)
    for j in range(count):
        g[j] = gall[K[j]] if smooth else 1.0
        rhs[j] = -g[j] * v[K[j]]  # eqs. 11/16, 15/18/21
    return K, g, rhs


@kernel
def iterate_null_space(
    E: Any,
    w: Any,
    q: Any,
    lp: Any,
    lam_dt: float,
    smooth: bool,
    extra: Any,
    has_extra: bool,
    max_levels: int,
    tol: float,
    robust: float,
) -> Any:
    """CM01's iterative scheme (eqs. 11-18, 21); ``max_levels < 0`` means no limit.

    Returns:
        ``(d, level_of, levels, steps, γ, unmet, σ_min)``: the null-space motion (n,), the
        level of each constrained axis (0 if none), the number of levels, the motion of
        each level (rows of an (n, n) array), γ (n,), per level (index 1..levels) whether
        it was met only in the least-squares sense, and the smallest singular value of the
        constraint rows used.
    """
    n = q.shape[0]
    N = np.ascontiguousarray(E)
    d = np.zeros(n)
    free = np.ones(n, dtype=np.bool_)
    gam = np.zeros(n)
    level_of = np.zeros(n, dtype=np.int64)
    steps = np.zeros((n, n))
    unmet = np.zeros(n + 1, dtype=np.bool_)
    min_sigma = np.inf
    v = w.copy()  # level 1: d = 0 and no extra term (eqs. 8, 16)
    last = n if max_levels < 0 else max_levels
    levels = 0
    q_hat = np.empty(n)
    for level in range(1, last + 1):
        if level > 1:
            for i in range(n):
                v[i] = (w[i] + extra[i] + d[i]) if has_extra else (w[i] + d[i])  # eqs. 12 / 20
        for i in range(n):
            q_hat[i] = q[i] - lam_dt * v[i]  # eq. 8, with the current level's control
        K, g, rhs = level_constraints(q, q_hat, lp, free, v, smooth)
        count = K.shape[0]
        if count == 0:
            break
        step, N, met, sig = constrain(N, K, rhs, tol, robust)
        min_sigma = min(min_sigma, sig)
        for i in range(n):
            d[i] = d[i] + step[i]
            steps[level - 1, i] = step[i]
        for j in range(count):
            free[K[j]] = False
            gam[K[j]] = g[j]
            level_of[K[j]] = level
        unmet[level] = not met
        levels = level
    return d, level_of, levels, steps, gam, unmet, min_sigma


@kernel
def pack_levels(E: Any, d: Any, steps: Any, unmet: Any, levels: int, vec: Any) -> bool:
    """Write ``vec = [a (n_a), b ((levels-1) n_a), unmet flag per level (levels)]``.

    ``a = Eᵀ d`` and ``b = Eᵀ`` (motion of levels 2, 3, ...) are in the null-space
    coordinates of ``E`` (n x n_a, orthonormal columns), the motions in rad or m per
    ``λ``; a flag is 1.0 when its level was met only in the least-squares sense.
    Returns whether any level was.
    """
    n, n_a = E.shape
    nb = max(levels - 1, 0)
    for j in range(n_a):  # a = E^T d, b = E^T (steps of levels 2, 3, ...)
        acc = 0.0
        for i in range(n):
            acc += E[i, j] * d[i]
        vec[j] = acc
    for lv in range(1, levels):
        for j in range(n_a):
            acc = 0.0
            for i in range(n):
                acc += E[i, j] * steps[lv, i]
            vec[n_a + (lv - 1) * n_a + j] = acc
    any_unmet = False
    for lv in range(1, levels + 1):
        vec[n_a + nb * n_a + lv - 1] = 1.0 if unmet[lv] else 0.0
        any_unmet = any_unmet or unmet[lv]
    return any_unmet


@kernel
def iterative(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    smooth: bool,
    alpha: float,
    max_levels: int,
    rcond: float,
    robust: float,
    tol: float,
    constraint_robust: float,
) -> Any:
    """``q̇ = -λ (J1⁺e + E a + α J1^⊥ e2) + J1^⊥ secondary`` (CM01 eqs. 10-21).

    ``alpha > 0`` adds the e2 term from level 2 on (eqs. 19-21). Outputs: ``axes`` the
    level of each constrained axis, ``axf`` γ, ``vec = [a (n_a), b ((levels-1) n_a),
    unmet flag per level (levels)]``, ``iout[I_NCON]`` the constrained axes,
    ``iout[I_NA]`` n_a, ``fout[F_MIN_SIGMA]`` the smallest constraint singular value.
    """
    n = J1.shape[1]
    _, sigma, V, rank, pinv, filtered = task_svd(J1, rcond, robust)
    n_a = n - rank
    E = np.empty((n, n_a))
    for i in range(n):
        for j in range(n_a):
            E[i, j] = V[i, rank + j]
    w = matvec(pinv, e)
    if has_sec:
        ns = null_project(V, rank, sec)
        for i in range(n):
            w[i] = w[i] - ns[i] / lam
    has_extra = alpha > 0.0
    extra = np.zeros(n)
    if has_extra:
        ge = null_project(V, rank, gradient(q, lp))
        for i in range(n):
            extra[i] = alpha * ge[i]
    d, level_of, levels, steps, gam, unmet, min_sigma = iterate_null_space(
        E, w, q, lp, lam * dt, smooth, extra, has_extra, max_levels, tol, constraint_robust
    )
    nb = max(levels - 1, 0)
    qdot, iout, fout, axes, axf, vec = new_outputs(n, n_a + nb * n_a + levels)
    for i in range(n):
        v = (w[i] + extra[i] + d[i]) if has_extra else (w[i] + d[i])
        qdot[i] = -lam * v
        axes[i] = level_of[i]
        axf[i] = gam[i]
    any_unmet = pack_levels(E, d, steps, unmet, levels, vec)
    ncon = 0
    for i in range(n):
        if level_of[i] > 0:
            ncon += 1
    svd_outputs(sigma, rank, filtered, iout, fout)
    iout[I_PROJ] = n_a
    iout[I_ITER] = levels
    iout[I_OVER] = 1 if (ncon > n_a or any_unmet) else 0
    iout[I_NCON] = ncon
    iout[I_NA] = n_a
    fout[F_MIN_SIGMA] = min_sigma
    return qdot, iout, fout, axes, axf, vec
