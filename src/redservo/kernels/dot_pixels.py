"""Compiled pixels of an exposure's dots: where each dot of each instant is drawn.

:func:`redservo.vision.motion_blur._dot_geometry` projects every instant's dots (their
camera points ``P``) through a pinhole camera without distortion and bounds each dot's disc
by a rectangle of pixels. :func:`dot_pixels` does it in one call with the operations of
the numpy code it replaces, element by element in the same order (``x / z · px + u0``,
``v − R − 2``, ``floor``/``ceil``, clipped to the image with numpy's NaN-propagating
``maximum``/``minimum``), so the frame is the same bit for bit
(tests/test_vision_dot_pixels.py). Units: metres (``P``), pixels.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["dot_pixels"]


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
