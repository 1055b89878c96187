"""Bounded least squares (the reduced problem of ``qp``): the reduction to the free joints'
QP and the expansion with its polish (rad/s or m/s; formulas: :mod:`redservo.redundancy.qp`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.linalg import matvec, task_svd

__all__ = ["ACTIVE_RTOL", "bls_expand", "bls_reduce", "polish"]

ACTIVE_RTOL = 1e-8


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
