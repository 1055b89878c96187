"""Compiled shape tests of a blob mask: aspect, holes, solidity and ellipse residual.

The tests of :func:`redservo.vision.blobs.shape_reason` as sums over the mask (a blob's
box with an empty 1-pixel frame, pixels), for the fast path of :mod:`redservo.kernels.blob`;
each limit is tightened by 5 % (``_MARGIN``) so that a blob the fast path accepts is one
the reference accepts too, and a blob near a limit is left to the reference.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["shape_ok"]

_MARGIN = 0.95
"""Shape limits are tightened by 5 % on the fast path."""


@kernel
def _holes(own: Any) -> int:
    """Pixels of ``own`` (a box with a 1-pixel empty frame) not 4-connected to the frame."""
    h, w = own.shape
    seen = np.zeros((h, w), np.bool_)
    stack = np.empty(h * w, np.int64)
    top = 0
    stack[0] = 0
    seen[0, 0] = True
    while top >= 0:
        idx = stack[top]
        top -= 1
        i, j = idx // w, idx % w
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            a, b = i + di, j + dj
            if 0 <= a < h and 0 <= b < w and not own[a, b] and not seen[a, b]:
                seen[a, b] = True
                top += 1
                stack[top] = a * w + b
    count = 0
    for i in range(h):
        for j in range(w):
            if not own[i, j] and not seen[i, j]:
                count += 1
    return count


@kernel
def _hull_area_perimeter(own: Any) -> Any:
    """Area and perimeter of the convex hull of the pixel centres of ``own`` (monotone chain)."""
    h, w = own.shape
    pts = np.empty((2 * h, 2), np.float64)
    k = 0
    for i in range(h):
        lo, hi = -1, -1
        for j in range(w):
            if own[i, j]:
                hi = j
                if lo < 0:
                    lo = j
        if lo >= 0:
            pts[k, 0], pts[k, 1] = lo, i
            pts[k + 1, 0], pts[k + 1, 1] = hi, i
            k += 2
    order = np.argsort(pts[:k, 0] * (h + 1) + pts[:k, 1])
    p = pts[:k][order]
    hull = np.empty((2 * k + 1, 2), np.float64)
    m = 0
    for rep in range(2):
        start = m
        for t in range(k):
            q = p[t] if rep == 0 else p[k - 1 - t]
            while m >= start + 2:
                ax, ay = hull[m - 1, 0] - hull[m - 2, 0], hull[m - 1, 1] - hull[m - 2, 1]
                bx, by = q[0] - hull[m - 2, 0], q[1] - hull[m - 2, 1]
                if ax * by - ay * bx > 0.0:
                    break
                m -= 1
            hull[m] = q
            m += 1
        m -= 1
    area = perim = 0.0
    for t in range(m):
        x0, y0, x1, y1 = hull[t, 0], hull[t, 1], hull[(t + 1) % m, 0], hull[(t + 1) % m, 1]
        area += x0 * y1 - x1 * y0
        perim += math.hypot(x1 - x0, y1 - y0)
    return 0.5 * abs(area), perim


@kernel
def shape_ok(own: Any, max_aspect: float, min_solidity: float, max_residual: float) -> bool:
    """The shape tests of ``shape_reason`` on ``own`` (box + 1-pixel frame), 5 % stricter."""
    h, w = own.shape
    n = s_x = s_y = s_xx = s_yy = s_xy = 0.0
    for i in range(h):
        for j in range(w):
            if own[i, j]:
                n += 1.0
                s_x += j
                s_y += i
                s_xx += j * j
                s_yy += i * i
                s_xy += i * j
    if n < 16.0:
        return True
    mx, my = s_x / n, s_y / n
    a = s_xx / n - mx * mx + 1.0 / 12.0
    c = s_yy / n - my * my + 1.0 / 12.0
    b = s_xy / n - mx * my
    half_tr, root = 0.5 * (a + c), math.hypot(0.5 * (a - c), b)
    lo, hi = half_tr - root, half_tr + root
    if lo <= 0.0 or math.sqrt(hi / lo) > _MARGIN * max_aspect:
        return False
    if _holes(own) > _MARGIN * (0.02 * n + 1.0):
        return False
    area, perim = _hull_area_perimeter(own)
    if n / (area + 0.5 * perim + 1.0) < min_solidity / _MARGIN:
        return False
    det = a * c - b * b
    s1 = s2 = 0.0
    nb = 0
    radii = np.empty(int(n), np.float64)
    for i in range(1, h - 1):
        for j in range(1, w - 1):
            if own[i, j] and not (
                own[i - 1, j] and own[i + 1, j] and own[i, j - 1] and own[i, j + 1]
            ):
                dx, dy = j - mx, i - my
                radii[nb] = math.sqrt(max(c * dx * dx - 2.0 * b * dx * dy + a * dy * dy, 0.0) / det)
                s1 += radii[nb]
                nb += 1
    if nb < 4:
        return True
    mean = s1 / nb
    for t in range(nb):
        s2 += (radii[t] / mean - 1.0) ** 2
    allowed = max_residual + 0.5 / math.sqrt(n / math.pi)
    return math.sqrt(s2 / nb) <= _MARGIN * allowed
