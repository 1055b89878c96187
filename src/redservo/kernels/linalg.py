"""Linear-algebra kernels: the task SVD, its pseudo-inverse and null-space products.

The formulas are those of :mod:`redservo.redundancy.linalg` (which wraps these kernels):
``J = U diag(σ) V^T``, rank ``r = #{σ_i > rcond σ_max}``, ``J⁺ = V_r diag(1/σ_r) U_r^T``
(with the bounded, filtered reciprocal ``σ/(ε σ_max)²`` below ``ε σ_max`` when the robust
threshold ``ε > 0``; docs/safety.md), ``E = V[:, r:]`` an orthonormal basis of ``Ker J``.
Products are written as loops: on the small matrices of a control step they cost a few
nanoseconds compiled, far less than a BLAS call.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.lapack import gesvd

__all__ = [
    "filtered_reciprocal",
    "matvec",
    "norm2",
    "null_project",
    "rmatvec",
    "svd_full",
    "task_svd",
]


@kernel
def svd_full(A: Any) -> Any:
    """``(U, σ, V)`` of ``A`` (m, n) by ``dgesvd``; numpy's driver if LAPACK did not converge."""
    U, s, V, info = gesvd(A)
    if info != 0:  # never seen on finite input; numpy's divide-and-conquer driver then
        U2, s2, Vt2 = np.linalg.svd(A)
        return np.ascontiguousarray(U2), s2, np.ascontiguousarray(Vt2.T)
    return U, s, V


@kernel
def filtered_reciprocal(sigma: Any, threshold: float) -> Any:
    """``1/σ`` for ``σ >= threshold`` and ``σ/threshold²`` below (bounded by 1/threshold)."""
    out = np.empty(sigma.shape[0])
    t2 = threshold * threshold
    for i in range(sigma.shape[0]):
        out[i] = 1.0 / sigma[i] if sigma[i] >= threshold else sigma[i] / t2
    return out


@kernel
def task_svd(J: Any, rcond: float, robust: float) -> Any:
    """``(U, σ, V, rank, J⁺, filtered)`` of ``J`` (m, n), see the module docstring.

    Args:
        J: (m, n) matrix, finite.
        rcond: Relative cut-off of the numerical rank.
        robust: Relative filter threshold ε of the bounded inverse, 0 for the exact ``J⁺``.

    Returns:
        U (m, m), σ (min(m, n),), V (n, n), the rank, ``J⁺`` (n, m) and the number of
        filtered singular values.
    """
    m, n = J.shape
    U, sigma, V = svd_full(J)
    k = sigma.shape[0]
    smax = sigma[0] if k > 0 else 0.0
    rank = 0
    if smax > 0.0:
        for i in range(k):
            if sigma[i] > rcond * smax:
                rank += 1
    filtered = 0
    pinv = np.zeros((n, m))
    if rank > 0:
        inv = np.empty(rank)
        thr = robust * smax
        use_filter = robust > 0.0 and sigma[rank - 1] < thr
        for i in range(rank):
            if use_filter and sigma[i] < thr:
                inv[i] = sigma[i] / (thr * thr)
                filtered += 1
            else:
                inv[i] = 1.0 / sigma[i]
        for i in range(n):
            for j in range(m):
                acc = 0.0
                for l in range(rank):
                    acc += V[i, l] * inv[l] * U[j, l]
                pinv[i, j] = acc
    return U, sigma, V, rank, pinv, filtered


@kernel
def matvec(A: Any, x: Any) -> Any:
    """``A x`` for A (m, n), x (n,)."""
    m, n = A.shape
    y = np.empty(m)
    for i in range(m):
        acc = 0.0
        for j in range(n):
            acc += A[i, j] * x[j]
        y[i] = acc
    return y


@kernel
def rmatvec(A: Any, x: Any) -> Any:
    """``A^T x`` for A (m, n), x (m,)."""
    m, n = A.shape
    y = np.zeros(n)
    for i in range(m):
        xi = x[i]
        for j in range(n):
            y[j] += A[i, j] * xi
    return y


@kernel
def null_project(V: Any, rank: int, x: Any) -> Any:
    """``E (E^T x)`` with ``E = V[:, rank:]``: the projection of x (n,) onto ``Ker J``."""
    n = V.shape[0]
    y = np.zeros(n)
    for k in range(rank, n):
        c = 0.0
        for i in range(n):
            c += V[i, k] * x[i]
        for i in range(n):
            y[i] += V[i, k] * c
    return y


@kernel
def norm2(x: Any) -> float:
    """Euclidean norm of a vector."""
    acc = 0.0
    for i in range(x.shape[0]):
        acc += x[i] * x[i]
    return float(np.sqrt(acc))
