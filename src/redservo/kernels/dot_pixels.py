"""Compiled geometry of an exposure's dots: where each dot of each instant is drawn.

:func:`redservo.vision.motion_blur._dot_geometry` brings every instant's dots into the
camera frame (``P``), projects them through a pinhole camera without distortion and bounds
each dot's disc by a rectangle of pixels. :func:`dot_points` and :func:`dot_pixels` do it
with the operations of the numpy code they replace: the products by BLAS in the same shapes
(``cMo = inverse(bMc) [· bMw] · wMo`` per instant and point set, ``P = pts · Rᵀ + t`` per
point set, as :meth:`redservo.scene.Scene.cMo` and the renderer compute them), the rest
element by element in the same order (``x / z · px + u0``, ``v − R − 2``,
``floor``/``ceil``, clipped to the image with numpy's NaN-propagating
``maximum``/``minimum``), so the frame is the same bit for bit
(tests/test_vision_dot_pixels.py). Units: metres (``P``), pixels.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.loop_task import inverse

__all__ = ["dot_pixels", "dot_points"]


@kernel
def dot_points(bMc: Any, wMo: Any, bMw: Any, has_base: bool, pts: Any, starts: Any) -> Any:
    """The camera points ``P`` (instants, dots, 3; m) of the point sets whose points are
    ``pts[starts[s]:starts[s + 1]]`` (their object frames, m), at the camera poses ``bMc``
    (instants, 4, 4) and object poses ``wMo`` (instants, sets, 4, 4), with the base
    ``bMw`` (4, 4) when ``has_base`` (else the base is the world)."""
    n_i, n_s = wMo.shape[0], wMo.shape[1]
    P = np.empty((n_i, pts.shape[0], 3))
    for i in range(n_i):
        cMw = inverse(np.ascontiguousarray(bMc[i]))
        if has_base:
            cMw = np.dot(cMw, bMw)
        for s in range(n_s):
            cMo = np.dot(cMw, np.ascontiguousarray(wMo[i, s]))
            R = np.ascontiguousarray(cMo[:3, :3])
            a, b = starts[s], starts[s + 1]
            Q = np.dot(np.ascontiguousarray(pts[a:b]), R.T)
            for j in range(b - a):
                for c in range(3):
                    P[i, a + j, c] = Q[j, c] + cMo[c, 3]
    return P


@kernel
def dot_pixels(P: Any, k: Any) -> Any:
    """``(UV, lo, hi, seen)`` of the camera points ``P`` (instants, dots, 3; m) with ``k =
    (px, py, u0, v0, R, h, w, min_depth)`` (focal lengths and principal point in pixels,
    the dots' radius R in pixels, the image's height and width, the nearest depth drawn in
    m): the pixels ``UV`` (instants, dots, 2), the rectangles' first rows and columns
    ``lo`` and ends ``hi`` (2, instants, dots: rows, then columns; clipped to the image)
    and whether each dot is drawn (in front, finite, a rectangle not empty)."""
    n_i, n_d = P.shape[0], P.shape[1]
    px, py, u0, v0, R, h, w, near = k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7]
    UV = np.empty((n_i, n_d, 2))
    lo = np.empty((2, n_i, n_d))
    hi = np.empty((2, n_i, n_d))
    seen = np.empty((n_i, n_d), np.bool_)
    for i in range(n_i):
        for j in range(n_d):
            z = P[i, j, 2]
            front = z > near
            if not front:
                z = 1.0
            u = P[i, j, 0] / z * px + u0
            v = P[i, j, 1] / z * py + v0
            UV[i, j, 0], UV[i, j, 1] = u, v
            ok = front and np.isfinite(u) and np.isfinite(v)
            for a, c, lim in ((0, v, h), (1, u, w)):
                first = np.floor(c - R - 2.0)
                end = np.ceil(c + R + 2.0)
                # numpy's maximum(first, 0) and minimum(end, lim): a NaN stays NaN
                lo[a, i, j] = first if (first >= 0.0 or first != first) else 0.0
                hi[a, i, j] = end if (end <= lim or end != end) else lim
                ok = ok and lo[a, i, j] < hi[a, i, j]
            seen[i, j] = ok
    return UV, lo, hi, seen
