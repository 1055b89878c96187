"""LAPACK's ``dgesvd`` for the kernels: the same Fortran routine on both paths.

``gesvd(A)`` returns ``(U, σ, V, info)`` for an (m, n) C-contiguous float64 ``A`` with
``A = U diag(σ) V^T``: U (m, m), σ (min(m, n),) descending, V (n, n) with the right
singular vectors as *columns*, all C-contiguous. It is exactly the decomposition that
``scipy.linalg.lapack.dgesvd(A)`` returns (same routine, same minimal workspace), so the
results are bit-for-bit those of the laws before the kernel layer.

* Compiled path: the kernel calls ``dgesvd`` from ``scipy.linalg.cython_lapack``
  through its address (a numba ``ExternalFunction`` resolved by symbol name, which keeps
  the calling kernels cacheable). No numpy wrapper, no Python object per call.
* Reference path (no numba): scipy's own f2py wrapper of the same routine.

``gesvd_sv(A)`` returns ``(σ, V, info)``: the same routine without the left vectors
(``jobu = 'N'``), for callers that use σ and V only (the moments' plane). LAPACK takes the
same steps on A either way (QR then bidiagonalisation, then the same implicit QR
iteration on the bidiagonal, since the right vectors are still asked for), applying the
rotations to U only when U is asked for, so σ and V are the bits of :func:`gesvd`
(tests/test_campaign_speedups.py, thousands of random, near-planar, scaled and
rank-deficient matrices).

This is the binding of one external routine for two calling conventions, not a second
implementation of any kernel.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import COMPILED, kernel

__all__ = ["gesvd", "gesvd_lwork", "gesvd_sv"]


@kernel
def gesvd_lwork(m: int, n: int) -> int:
    """Workspace size scipy's wrapper uses by default, ``max(3 k + max(m, n), 5 k, 1)``."""
    k = min(m, n)
    return max(max(3 * k + max(m, n), 5 * k), 1)


if COMPILED:
    import llvmlite.binding as _llvm
    from numba import types as _types
    from numba.extending import get_cython_function_address

    _SYMBOL = "redservo_cython_dgesvd"
    _llvm.add_symbol(_SYMBOL, get_cython_function_address("scipy.linalg.cython_lapack", "dgesvd"))
    _dgesvd: Any = _types.ExternalFunction(_SYMBOL, _types.void(*([_types.voidptr] * 14)))

    @kernel
    def _run_dgesvd(A: Any, jobu: int) -> Any:
        """``(Uᵀ, σ, V, info)``: ``dgesvd`` on a Fortran copy of ``A`` (m, n), every row of
        ``Vᵀ``; ``jobu`` 65 (``'A'``, Uᵀ (m, m) in C order) or 78 (``'N'``, no column of U:
        Uᵀ a (1, 1) placeholder LAPACK does not touch)."""
        m, n = A.shape
        k = min(m, n)
        a = np.empty((n, m))  # C-order A^T = Fortran-order A (overwritten by LAPACK)
        for i in range(m):
            for j in range(n):
                a[j, i] = A[i, j]
        mu = m if jobu == 65 else 1
        ut = np.empty((mu, mu))  # Fortran U = C-order U^T
        v = np.empty((n, n))  # Fortran V^T = C-order V
        s = np.empty(k)
        lwork = gesvd_lwork(m, n)
        work = np.empty(lwork)
        ip = np.empty(7, dtype=np.int32)
        ip[0] = m
        ip[1] = n
        ip[2] = max(m, 1)
        ip[3] = max(mu, 1)
        ip[4] = max(n, 1)
        ip[5] = lwork
        ip[6] = 0
        job = np.empty(2, dtype=np.uint8)
        job[0] = jobu
        job[1] = 65  # 'A': every row of V^T
        _dgesvd(
            job[0:].ctypes,
            job[1:].ctypes,
            ip[0:].ctypes,
            ip[1:].ctypes,
            a.ctypes,
            ip[2:].ctypes,
            s.ctypes,
            ut.ctypes,
            ip[3:].ctypes,
            v.ctypes,
            ip[4:].ctypes,
            work.ctypes,
            ip[5:].ctypes,
            ip[6:].ctypes,
        )
        return ut, s, v, int(ip[6])

    @kernel
    def gesvd(A: Any) -> Any:
        """Full SVD of ``A`` (m, n) by LAPACK ``dgesvd`` (module docstring)."""
        ut, s, v, info = _run_dgesvd(A, 65)
        m = A.shape[0]
        U = np.empty((m, m))
        for i in range(m):
            for j in range(m):
                U[i, j] = ut[j, i]
        return U, s, v, info

    @kernel
    def gesvd_sv(A: Any) -> Any:
        """``(σ, V, info)`` of ``A`` (m, n) by ``dgesvd`` without the left vectors
        (``jobu = 'N'``): the same σ and V as :func:`gesvd` (module docstring)."""
        _, s, v, info = _run_dgesvd(A, 78)
        return s, v, info

else:

    def gesvd(A: Any) -> Any:
        """Full SVD of ``A`` (m, n) by LAPACK ``dgesvd`` (module docstring)."""
        from scipy.linalg import lapack

        U, s, Vt, info = lapack.dgesvd(A)
        return np.ascontiguousarray(U), s, np.ascontiguousarray(Vt.T), int(info)

    def gesvd_sv(A: Any) -> Any:
        """``(σ, V, info)`` of ``A`` (m, n) by ``dgesvd`` (scipy's wrapper computes U too)."""
        _, s, V, info = gesvd(A)
        return s, V, info
