"""Compiled dot search in a small window: labelling, shape tests and the clipped centroid.

The fast path of :class:`redservo.vision.tracking.ImageDotTracker` (its module docstring
gives the method): one call per dot and frame thresholds a window around the dot's
prediction at one gray level, labels its 8-connected components, and takes the components
nearest the prediction in turn through the tracker's tests, computed as moment sums over
the window instead of one numpy reduction per quantity:

* size, area, window edge and image border, as ``ImageDotTracker._check``;
* the shape tests of :func:`redservo.vision.blobs.shape_reason` (aspect from the second
  moments, holes by filling the background from the blob's box, solidity against the
  convex hull of the pixel centres, ellipse residual of the boundary pixels), each with a
  5 % margin: a blob close to a limit is left to the reference path;
* the clipped centroid of :func:`redservo.vision.blobs.measure_blob`: support (mask
  dilated by a disc of radius ``p``) and ring (``p + 2``) without the other components,
  plateau = upper median of the eroded mask, background = upper median of the ring,
  weights ``clip((I - b) / (L - b), 0, 1)``.

The kernel only ever *accepts* a blob; anything it cannot decide (no component passes, a
non-uniform ring that needs the per-pixel background, a support clipped by the window)
returns ``FALLBACK`` and the caller runs the reference search. Coordinates: pixel
``(row i, col j)`` is centred at ``(u, v) = (j + 0.5, i + 0.5)`` (pixels).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.blob_shape import shape_ok

__all__ = ["FALLBACK", "FOUND", "window_dot"]

FOUND = 0
"""Code of an accepted blob."""
FALLBACK = 1
"""Code of a window the kernel leaves to the reference path."""


@kernel
def _label(mask: Any) -> Any:
    """8-connected labels (0 = background) of ``mask`` and per label ``x0, y0, x1, y1, n``."""
    h, w = mask.shape
    labels = np.zeros((h, w), np.int32)
    stats = np.empty((h * w // 2 + 2, 5), np.int64)  # rows set as labels are made
    stats[0] = 0
    stack = np.empty(h * w, np.int64)
    n = 0
    for i0 in range(h):
        for j0 in range(w):
            if not mask[i0, j0] or labels[i0, j0]:
                continue
            n += 1
            labels[i0, j0] = n
            stats[n, 0], stats[n, 1], stats[n, 2], stats[n, 3] = j0, i0, j0, i0
            stats[n, 4] = 0
            top = 0
            stack[0] = i0 * w + j0
            while top >= 0:
                idx = stack[top]
                top -= 1
                i, j = idx // w, idx % w
                stats[n, 0] = min(stats[n, 0], j)
                stats[n, 1] = min(stats[n, 1], i)
                stats[n, 2] = max(stats[n, 2], j)
                stats[n, 3] = max(stats[n, 3], i)
                stats[n, 4] += 1
                for di in range(-1, 2):
                    for dj in range(-1, 2):
                        a, b = i + di, j + dj
                        if 0 <= a < h and 0 <= b < w and mask[a, b] and not labels[a, b]:
                            labels[a, b] = n
                            top += 1
                            stack[top] = a * w + b
    return labels, stats[: n + 1]


@kernel
def _dilate(own: Any, disc: Any) -> Any:
    """``own`` dilated by the structuring element ``disc`` (odd square, centred, each row one
    centred run: an ellipse), run by run: each run of ``own`` widened by every disc row's
    half-width."""
    h, w = own.shape
    r = disc.shape[0] // 2
    widths = np.full(2 * r + 1, -1, np.int64)
    for a in range(2 * r + 1):
        for b in range(2 * r + 1):
            if disc[a, b]:
                widths[a] = max(widths[a], abs(b - r))
    out = np.zeros((h, w), np.bool_)
    for i in range(h):
        j = 0
        while j < w:
            if not own[i, j]:
                j += 1
                continue
            lo = j
            while j < w and own[i, j]:
                j += 1
            for a in range(-r, r + 1):
                ra = widths[a + r]
                if ra < 0 or not 0 <= i + a < h:
                    continue
                for b in range(max(lo - ra, 0), min(j + ra, w)):
                    out[i + a, b] = True
    return out


@kernel
def _hist_median(hist: Any, n: int) -> float:
    """The upper median (the ``n // 2``-th smallest, ``np.partition(x, n // 2)[n // 2]``)
    of ``n`` gray levels counted in ``hist`` (256,), without sorting them."""
    k, seen = n // 2, 0
    for v in range(256):
        seen += hist[v]
        if seen > k:
            return float(v)
    return 255.0


@kernel
def _levels(roi: Any, own: Any, ring: Any, bright: bool) -> Any:
    """Plateau (upper median of ``own`` eroded by 3 x 3, else its extreme), background
    (upper median of the ring, else of the pixels outside ``own``) and the ring's std."""
    h, w = own.shape
    hists = np.zeros((3, 256), np.int64)  # core, ring, rest
    ring_v = np.empty(h * w, np.float64)
    nc = nr = no = 0
    ext = -1.0 if bright else 256.0
    for i in range(h):
        for j in range(w):
            g = roi[i, j]
            v = float(g)
            if own[i, j]:
                ext = max(ext, v) if bright else min(ext, v)
                inner = 0 < i < h - 1 and 0 < j < w - 1
                for a in range(-1, 2):
                    for b in range(-1, 2):
                        inner = inner and own[i + a, j + b]
                if inner:
                    hists[0, g] += 1
                    nc += 1
            else:
                hists[2, g] += 1
                no += 1
            if ring[i, j]:
                ring_v[nr] = v
                hists[1, g] += 1
                nr += 1
    level = _hist_median(hists[0], nc) if nc else ext
    bg = _hist_median(hists[1], nr) if nr >= 4 else _hist_median(hists[2], no)
    std = float(np.std(ring_v[:nr])) if nr >= 4 else 0.0
    return level, bg, std


@kernel
def _centroid(roi: Any, own: Any, other: Any, disc_p: Any, disc_ring: Any, bright: bool) -> Any:
    """``(code, u, v, level, background)`` of the blob ``own`` in ``roi`` (window pixels)."""
    h, w = own.shape
    support = _dilate(own, disc_p)
    ring = _dilate(own, disc_ring)
    for i in range(h):
        for j in range(w):
            support[i, j] = support[i, j] and not other[i, j]
            ring[i, j] = ring[i, j] and not support[i, j] and not other[i, j]
    level, bg, std = _levels(roi, own, ring, bright)
    contrast = level - bg if bright else bg - level
    if contrast <= 2.0 or std > 0.1 * contrast:
        return FALLBACK, 0.0, 0.0, level, bg  # low contrast, or a per-pixel background
    total = su = sv = 0.0
    for i in range(h):
        for j in range(w):
            if support[i, j]:
                wt = min(max((float(roi[i, j]) - bg) / (level - bg), 0.0), 1.0)
                total += wt
                su += wt * (j + 0.5)
                sv += wt * (i + 0.5)
    if total <= 0.0:
        return FALLBACK, 0.0, 0.0, level, bg
    u, v = su / total, sv / total
    ci, cj = int(v), int(u)
    near = False
    for a in range(max(ci - 1, 0), min(ci + 2, h)):
        for b in range(max(cj - 1, 0), min(cj + 2, w)):
            near = near or own[a, b]
    return (FOUND if near else FALLBACK), u, v, level, bg


@kernel
def _passes(stats: Any, k: int, where: Any, sizes: Any, ref_area: float, known: bool) -> bool:
    """The size, edge and border tests of ``ImageDotTracker._check`` at the first level."""
    c0, r0, ww, wh, big_w, big_h = where
    x, y = stats[k, 0], stats[k, 1]
    w, h, area = stats[k, 2] - x + 1, stats[k, 3] - y + 1, stats[k, 4]
    if x + c0 == 0 or y + r0 == 0 or x + c0 + w == big_w or y + r0 + h == big_h:
        return False
    if x == 0 or y == 0 or x + w == ww or y + h == wh:
        return False
    min_size, max_size, p2 = sizes
    if max(w, h) > max_size or (known and area > ref_area / p2):
        return False
    return not (max(w, h) < min_size or (known and area < p2 * ref_area))


@kernel
def window_dot(img: Any, params: Any, discs: Any) -> Any:
    """The dot's blob in a window around its prediction (one call per dot and frame).

    Args:
        img: (H, W) uint8 image.
        params: (15,) ``u, v`` the prediction (pixels); ``half`` the window's half-size
            (pixels); ``gate`` the largest distance (pixels) from the prediction to a
            component's box centre, plus half its size; ``thr`` the mask's gray level (above
            it for bright dots, below for dark ones); ``bright`` (1 or 0); ``min_size_px,
            max_size_px, size_precision²``; ``ref_area`` the dot's last area (pixels, NaN
            when unknown); ``pad`` the margin (pixels) of the centroid's support; ``check,
            max_aspect, min_solidity, max_ellipse_residual`` the shape tests (check 0: none).
        discs: (2, D, D) uint8 discs of radius ``p`` and ``p + 2`` (zero-padded to D).

    Returns:
        (7,) ``code, u, v, area, size, level, background`` (pixels, gray levels).
    """
    centre, half, gate, thr = params[0:2], params[2], params[3], params[4]
    bright, sizes, ref_area, pad, shape = (
        params[5] > 0.0,
        params[6:9],
        params[9],
        params[10],
        params[11:15],
    )
    out = np.zeros(7)
    out[0] = FALLBACK
    H, W = img.shape
    c0, c1 = max(int(centre[0] - half), 0), min(int(centre[0] + half) + 1, W)
    r0, r1 = max(int(centre[1] - half), 0), min(int(centre[1] + half) + 1, H)
    if c1 - c0 < 2 or r1 - r0 < 2:
        return out
    win = img[r0:r1, c0:c1]
    mask = (win > thr) if bright else (win < thr)
    labels, stats = _label(mask)
    n = stats.shape[0] - 1
    dist = np.empty(n)
    for k in range(1, n + 1):
        du = stats[k, 0] + 0.5 * (stats[k, 2] - stats[k, 0] + 1) + c0 - centre[0]
        dv = stats[k, 1] + 0.5 * (stats[k, 3] - stats[k, 1] + 1) + r0 - centre[1]
        dist[k - 1] = math.hypot(du, dv)
    where = (c0, r0, c1 - c0, r1 - r0, W, H)
    p = max(math.ceil(pad), 1)
    m = p + 3
    for k0 in np.argsort(dist):
        k = k0 + 1
        x, y = stats[k, 0], stats[k, 1]
        w, h = stats[k, 2] - x + 1, stats[k, 3] - y + 1
        if dist[k0] > gate + 0.5 * max(w, h):
            break
        if not _passes(stats, k, where, sizes, ref_area, ref_area == ref_area):
            continue
        if y < m or x < m or y + h + m > r1 - r0 or x + w + m > c1 - c0:
            return out  # the support is clipped by the window: the reference decides
        if shape[0] > 0.0:
            own = labels[y - 1 : y + h + 1, x - 1 : x + w + 1] == k
            if not shape_ok(own, shape[1], shape[2], shape[3]):
                return out
        lab = labels[y - m : y + h + m, x - m : x + w + m]
        own = lab == k
        other = (lab > 0) & ~own
        roi = win[y - m : y + h + m, x - m : x + w + m]
        code, u, v, level, bg = _centroid(roi, own, other, discs[0], discs[1], bright)
        if code != FOUND:
            return out
        out[0], out[1], out[2] = FOUND, u + x - m + c0, v + y - m + r0
        out[3], out[4], out[5], out[6] = stats[k, 4], max(w, h), level, bg
        return out
    return out
