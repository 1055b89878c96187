"""Compiled predicted image motion of tracked dots (:mod:`redservo.vision.motion`).

Through a camera without distortion, :func:`redservo.vision.motion.camera_shift` takes the
dots' pixels to normalized coordinates (:func:`normalized`), their inverse depths from the
terms, the camera's motion ``cMc' = bMc⁻¹ · bMc'`` from numpy's ``solve`` (LAPACK, kept in
numpy: its bits are numpy's), and then the shift of every dot in one call (:func:`shift`):
``P = (x, y, 1) / ρ`` of the usable dots (finite pixels, ``ρ > 0``), ``Q = P · Rᵀ + t`` (the
product by BLAS, in numpy's shapes, as :mod:`redservo.kernels.dot_pixels`), and the pixels
of the dots in front minus their last ones, element by element in numpy's order, so the
shift is the same bit for bit (tests/test_vision_motion_kernel.py). Units: pixels, 1/m.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["normalized", "shift"]


@kernel
def normalized(uv: Any, k: Any) -> Any:
    """Normalized coordinates (n, 2) of the pixels ``uv`` (n, 2) with ``k = (px, py, u0,
    v0, ...)`` (pixels): ``(u − u0) / px``, ``(v − v0) / py``."""
    n = uv.shape[0]
    xy = np.empty((n, 2))
    for i in range(n):
        xy[i, 0] = (uv[i, 0] - k[2]) / k[0]
        xy[i, 1] = (uv[i, 1] - k[3]) / k[1]
    return xy


@kernel
def shift(uv: Any, xy: Any, rho: Any, cMc: Any, k: Any) -> Any:
    """Image motion (n, 2) in pixels of the dots at ``uv`` (n, 2; ``xy`` normalized) with
    inverse depths ``rho`` (n,) (1/m) in the camera's motion ``cMc`` (4, 4; the old camera
    frame in the new one), ``k = (px, py, u0, v0, min_depth)`` (pixels, m); NaN for a dot
    without a finite pixel, a positive depth or a point in front of the new camera."""
    n = uv.shape[0]
    out = np.full((n, 2), np.nan)
    rows = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        r = rho[i]
        if np.isfinite(r) and r > 0.0 and np.isfinite(uv[i, 0]) and np.isfinite(uv[i, 1]):
            rows[m] = i
            m += 1
    if m == 0:
        return out
    P = np.empty((m, 3))
    for j in range(m):
        i = rows[j]
        P[j, 0], P[j, 1], P[j, 2] = xy[i, 0] / rho[i], xy[i, 1] / rho[i], 1.0 / rho[i]
    Q = np.dot(P, np.ascontiguousarray(cMc[:3, :3]).T)
    for j in range(m):
        z = Q[j, 2] + cMc[2, 3]
        if z > k[4]:
            i = rows[j]
            out[i, 0] = (Q[j, 0] + cMc[0, 3]) / z * k[0] + k[2] - uv[i, 0]
            out[i, 1] = (Q[j, 1] + cMc[1, 3]) / z * k[1] + k[3] - uv[i, 1]
    return out
