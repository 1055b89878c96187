"""Compiled check of a PnP pose: every point in front, and the RMS reprojection error.

:func:`redservo.vision.pnp._checked` judges each pose OpenCV's solve returns (one or more a
frame): ``Pc = P · Rᵀ + t`` (the product by BLAS, in numpy's very shapes), every depth above
1e-6 m, the pixels ``x / z · f + c``, and ``sqrt(mean(Σ (proj − uv)²))``. Its dozen numpy
calls on four points cost more than OpenCV's solve. :func:`reprojection_rms` does the same
operations in the same order in one call: the product by ``np.dot`` (BLAS, as
:mod:`redservo.kernels.dot_pixels`), the element-wise steps as numpy rounds them, the
row sums ``a + b`` and the mean as numpy's ``add.reduce`` sums (one accumulator below 8
terms, eight then their pairwise sum up to 128), so the error is the same bit for bit
(tests/test_vision_pnp_kernel.py). Units: metres (points, translation), pixels.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["reprojection_rms"]


@kernel
def _numpy_sum(a: Any) -> float:
    """``np.add.reduce(a)`` of a 1-D array of at most 128 terms, in numpy's order."""
    n = a.shape[0]
    if n < 8:
        s = 0.0
        for i in range(n):
            s += a[i]
        return s
    r = a[:8].copy()
    i = 8
    while i < n - n % 8:
        for j in range(8):
            r[j] += a[i + j]
        i += 8
    s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        s += a[i]
        i += 1
    return s


@kernel
def reprojection_rms(P: Any, uv: Any, T: Any, k: Any) -> float:
    """The RMS reprojection error (pixels) of the points ``P`` (n, 3; m, object frame; n at
    most 128, numpy's pairwise block) seen at the pixels ``uv`` (n, 2) in the pose ``T`` (4, 4) with
    ``k = (px, py, u0, v0)`` (pixels); -1.0 when ``T`` is not finite or a point is not in
    front of the camera (deeper than 1e-6 m)."""
    for i in range(4):
        for j in range(4):
            if not np.isfinite(T[i, j]):
                return -1.0
    Q = np.dot(P, np.ascontiguousarray(T[:3, :3]).T)
    n = P.shape[0]
    for i in range(n):
        if not Q[i, 2] + T[2, 3] > 1e-6:
            return -1.0
    sq = np.empty(n)
    for i in range(n):
        x, y, z = Q[i, 0] + T[0, 3], Q[i, 1] + T[1, 3], Q[i, 2] + T[2, 3]
        du = x / z * k[0] + k[2] - uv[i, 0]
        dv = y / z * k[1] + k[3] - uv[i, 1]
        sq[i] = du * du + dv * dv
    return math.sqrt(_numpy_sum(sq) / n)
