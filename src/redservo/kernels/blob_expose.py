"""Compiled exposure of a scene of dots: the motion-blurred footprints composited in patches.

:func:`redservo.vision.motion_blur.exposed_frame` of a scene of point sets builds, per dot,
the mean coverage of its discs over the exposure's instants (a layer), orders the layers
far to near, merges their rectangles (widened by the optical blur's margin) into disjoint
patches and composites each patch over the background (float32,
``I ← I + α (level − I)``), whose difference to the background the renderer then blurs
(:meth:`redservo.vision.render.Renderer.lazy`). :func:`expose_dots` does all of it but the
blur in one call, with the same operations in the same order (float64 coverage summed over
the instants in order, divided by their number, rounded once to float32; float32
compositing), so the frame is the same bit for bit (tests/test_vision_exposure.py).
Units: pixels, gray levels.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["expose_dots"]


@kernel
def _layers(uv: Any, z: Any, seen: Any, lo: Any, hi: Any) -> Any:
    """The dots drawn (``order``, far to near), the instants of each (``inst`` rows of
    ``seen`` per dot, in order) and their rectangles ``(r0, r1, c0, c1)``."""
    n_i, n_d = seen.shape
    first = np.full(n_d, -1, np.int64)  # the order dots are met in: instant, then far first
    n_met = 0
    met = np.empty(n_d, np.int64)
    for i in range(n_i):
        k = np.flatnonzero(seen[i])
        for j in k[np.argsort(-z[i, k], kind="mergesort")]:
            if first[j] < 0:
                first[j] = i
                met[n_met] = j
                n_met += 1
    dots = met[:n_met]
    depth = np.empty(n_met)
    rects = np.empty((n_met, 4), np.int64)
    for t in range(n_met):
        j = dots[t]
        s, c = 0.0, 0
        r0 = c0 = 1 << 40
        r1 = c1 = -(1 << 40)
        for i in range(n_i):
            if seen[i, j]:
                s += z[i, j]
                c += 1
                r0, r1 = min(r0, int(lo[0, i, j])), max(r1, int(hi[0, i, j]))
                c0, c1 = min(c0, int(lo[1, i, j])), max(c1, int(hi[1, i, j]))
        depth[t] = s / c
        rects[t, 0], rects[t, 1], rects[t, 2], rects[t, 3] = r0, r1, c0, c1
    order = np.argsort(-depth, kind="mergesort")
    return dots[order], rects[order]


@kernel
def _merge(rects: Any) -> Any:
    """``redservo.vision.render._merge``: the merged rectangles and each input's group."""
    n = rects.shape[0]
    g_rect = rects.copy()
    g_of = np.arange(n)
    merged = True
    while merged:
        merged = False
        out = np.empty_like(g_rect)
        remap = np.empty(g_rect.shape[0], np.int64)
        no = 0
        for g in range(g_rect.shape[0]):
            a = g_rect[g]
            hit = -1
            for k in range(no):
                b = out[k]
                if a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]:
                    hit = k
                    break
            if hit >= 0:
                b = out[hit]
                out[hit, 0], out[hit, 1] = min(a[0], b[0]), max(a[1], b[1])
                out[hit, 2], out[hit, 3] = min(a[2], b[2]), max(a[3], b[3])
                remap[g] = hit
                merged = True
            else:
                out[no] = a
                remap[g] = no
                no += 1
        g_of = remap[g_of]
        g_rect = out[:no].copy()
    return g_rect, g_of


@kernel
def _composite(patch: Any, r0: int, c0: int, rect: Any, cu: Any, cv: Any, k: Any) -> None:
    """Composite one dot's mean disc coverage (``k`` = radius, level, instants) in ``patch``
    whose corner is pixel ``(r0, c0)``."""
    radius, level, n = k[0], np.float32(k[1]), k[2]
    edge = radius + 0.5
    for i in range(rect[0], rect[1]):
        for j in range(rect[2], rect[3]):
            a = 0.0
            for t in range(cu.shape[0]):
                du, dv = (j + 0.5) - cu[t], (i + 0.5) - cv[t]
                a += min(max(edge - math.sqrt(du**2 + dv**2), 0.0), 1.0)
            alpha = np.float32(a / n)
            sub = patch[i - r0, j - c0]
            patch[i - r0, j - c0] = sub + alpha * (level - sub)


@kernel
def expose_dots(uv: Any, z: Any, seen: Any, lo: Any, hi: Any, bg: Any, k: Any) -> Any:
    """The patches of a frame exposed over instants (``motion_blur._dot_layers`` + ``lazy``).

    Args:
        uv: (I, N, 2) each dot's pixel position at each instant.
        z: (I, N) its depth (m); seen: (I, N) bool drawn at that instant.
        lo, hi: (2, I, N) its disc's rectangle (rows, then columns; floor/ceil, clipped).
        bg: (H, W) float32 the unblurred background.
        k: (4,) ``radius`` (px), ``level`` (gray), instants ``I``, blur margin ``m`` (px).

    Returns:
        ``(boxes, deltas)``: (P, 4) int64 the patches (rows, then columns, half-open) and
        float32 their ``composited − background`` values, row-major, concatenated.
    """
    h, w = bg.shape
    dots, rects = _layers(uv, z, seen, lo, hi)
    m = int(k[3])
    wide = np.empty_like(rects)
    for t in range(rects.shape[0]):
        wide[t, 0], wide[t, 1] = max(rects[t, 0] - m, 0), min(rects[t, 1] + m, h)
        wide[t, 2], wide[t, 3] = max(rects[t, 2] - m, 0), min(rects[t, 3] + m, w)
    boxes, group = _merge(wide)
    size = 0
    for g in range(boxes.shape[0]):
        size += (boxes[g, 1] - boxes[g, 0]) * (boxes[g, 3] - boxes[g, 2])
    deltas = np.empty(size, np.float32)
    start = 0
    for g in range(boxes.shape[0]):
        r0, r1, c0, c1 = boxes[g, 0], boxes[g, 1], boxes[g, 2], boxes[g, 3]
        base = bg[r0:r1, c0:c1]
        patch = base.copy()
        for t in range(dots.shape[0]):  # in layer order: far to near
            if group[t] == g:
                j = dots[t]
                inst = np.flatnonzero(seen[:, j])
                _composite(patch, r0, c0, rects[t], uv[inst, j, 0], uv[inst, j, 1], k)
        n = (r1 - r0) * (c1 - c0)
        deltas[start : start + n] = (patch - base).ravel()
        start += n
    return boxes, deltas
