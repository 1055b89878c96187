"""Compiled frame of the dot tracker: every tracked dot searched in one call.

The fast path of :class:`redservo.vision.tracking.ImageDotTracker` for the common frame,
where every dot was found in the last frame: per dot, in index order, the window of
:func:`redservo.vision.fastdot.window_blob` (composed first from the frame's parts when the
frame is a :class:`~redservo.vision.lazyframe.LazyFrame`, :func:`compose_region`), searched
by :func:`~redservo.kernels.blob.window_dot`, refused when it is the blob of a dot found
before it; then the tracker's geometry check (each dot against the similarity the other
found dots give it, :func:`redservo.vision.fastdot.similarity_prediction`, in Python's
complex arithmetic written out: the same operations in the same order). The kernel only
accepts the whole frame: a dot it cannot decide, a merged dot or a dot off the geometry
returns ``accepted = False`` and the caller runs the tracker's own update, unchanged.
Compiled only: ``math.hypot`` here is libm's ``hypot`` under numba, the one Python's
``abs(complex)`` uses; plain Python's ``math.hypot`` rounds otherwise.
Units: pixels, gray levels.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.blob import FOUND, window_dot
from redservo.kernels.compose import compose_region

__all__ = ["track_frame"]


@kernel
def _cdiv(re: float, im: float, d: float) -> Any:
    """Python's ``complex(re, im) / d`` for a real ``d`` (its ``_Py_c_quot``)."""
    ratio = 0.0 / d
    denom = d + 0.0 * ratio
    return (re + im * ratio) / denom, (im - re * ratio) / denom


@kernel
def _geometry(ref: Any, cur: Any, found: Any, target: int) -> Any:
    """``similarity_prediction(ref, cur, found)``: dot ``target``'s predicted position
    ``(u, v)`` and the spread (pixels), complex numbers as (re, im) pairs."""
    n = found.shape[0]
    r0r = r0i = c0r = c0i = 0.0
    for t in range(n):
        r0r, r0i = r0r + ref[found[t], 0], r0i + ref[found[t], 1]
    for t in range(n):
        c0r, c0i = c0r + cur[t, 0], c0i + cur[t, 1]
    r0r, r0i = _cdiv(r0r, r0i, float(n))
    c0r, c0i = _cdiv(c0r, c0i, float(n))
    nr = ni = den = 0.0
    for t in range(n):
        dr, di = ref[found[t], 0] - r0r, ref[found[t], 1] - r0i
        er, ei = cur[t, 0] - c0r, cur[t, 1] - c0i
        nr, ni = nr + (dr * er - (-di) * ei), ni + (dr * ei + (-di) * er)
        den += math.hypot(dr, di) ** 2
    ar, ai = _cdiv(nr, ni, max(den, 1e-12))
    br, bi = c0r - (ar * r0r - ai * r0i), c0i - (ar * r0i + ai * r0r)
    m = ref.shape[0]
    z = np.empty((m, 2))
    mr = mi = 0.0
    for t in range(m):
        z[t, 0] = (ar * ref[t, 0] - ai * ref[t, 1]) + br
        z[t, 1] = (ar * ref[t, 1] + ai * ref[t, 0]) + bi
        mr, mi = mr + z[t, 0], mi + z[t, 1]
    mr, mi = _cdiv(mr, mi, float(m))
    s = 0.0
    for t in range(m):
        s += math.hypot(z[t, 0] - mr, z[t, 1] - mi) ** 2
    return z[target, 0], z[target, 1], math.sqrt(s / m)


@kernel
def _off_geometry(uv: Any, sizes: Any, ref: Any, tol: float) -> bool:
    """True when a dot is farther from where the others (>= 2) put it than its gate
    (``ImageDotTracker._off_geometry`` with every dot found)."""
    n = uv.shape[0]
    if n < 3:
        return False
    for i in range(n):
        found = np.empty(n - 1, np.int64)
        k = 0
        for j in range(n):
            if j != i:
                found[k] = j
                k += 1
        gu, gv, spread = _geometry(ref, uv[found], found, i)
        gate = max(2.0 * sizes[i], tol * spread)
        if math.hypot(uv[i, 0] - gu, uv[i, 1] - gv) > gate:
            return True
    return False


@kernel
def track_frame(
    pixels: Any,
    lazy: bool,
    bgb: Any,
    field: Any,
    offset: Any,
    sigma: float,
    boxes: Any,
    deltas: Any,
    gain: Any,
    has_gain: bool,
    dots: Any,
    moves: Any,
    settings: Any,
    discs: Any,
    ref: Any,
) -> Any:
    """Every dot of a frame where all were found last time, or not accepted.

    Args:
        pixels: (H, W) uint8 the frame (when ``lazy``: its buffer, composed here where read).
        lazy: Compose the windows from the frame's parts first.
        bgb, field, offset, sigma, boxes, deltas, gain, has_gain: The frame's parts, as
            :func:`compose_region` takes them (any when not ``lazy``).
        dots: (N, 6) each dot's ``u, v, level, background, area, size`` (finite).
        moves: (N, 2) each dot's predicted motion.
        settings: (14,) ``p, slack, max_jump, polarity (1 bright), min_size, max_size,
            size_precision², pad, has_limits, shape limits (3), has_ref, geometry_tol``.
        discs: (2, D, D) uint8 the support's and ring's discs (``fastdot._discs``).
        ref: (N, 2) the dots' reference positions (any when ``has_ref`` is 0).

    Returns:
        ``(accepted, found, rects)``: ``found`` (N, 7) per dot ``code, u, v, area, size,
        level, background``; ``rects`` (N, 4) the windows composed (rows, then columns).
    """
    n = dots.shape[0]
    h, w = pixels.shape
    found = np.zeros((n, 7))
    rects = np.zeros((n, 4), np.int64)
    params = np.empty(15)
    p, slack, jump = settings[0], settings[1], settings[2]
    for i in range(n):
        pu, pv = dots[i, 0] + moves[i, 0], dots[i, 1] + moves[i, 1]
        level, bg, size = dots[i, 2], dots[i, 3], dots[i, 5]
        params[0], params[1] = pu, pv
        params[2] = 0.5 * size + p + 4.0 + slack
        params[3] = jump + size
        params[4] = bg + 0.5 * (level - bg)
        params[5:9] = settings[3:7]
        params[9] = dots[i, 4]
        params[10] = settings[7]
        params[11:15] = settings[8:12]
        if lazy:
            half = params[2]
            r0, c0 = max(int(pv - half), 0), max(int(pu - half), 0)
            r1, c1 = min(int(pv + half) + 1, h), min(int(pu + half) + 1, w)
            if r0 < r1 and c0 < c1:
                rects[i, 0], rects[i, 1], rects[i, 2], rects[i, 3] = r0, r1, c0, c1
                pixels[r0:r1, c0:c1] = compose_region(
                    rects[i], bgb, field, offset, sigma, boxes, deltas, gain, has_gain
                )
        out = window_dot(pixels, params, discs)
        if out[0] != FOUND:
            return False, found, rects
        for j in range(i):
            if math.hypot(out[1] - found[j, 1], out[2] - found[j, 2]) < 0.5 * (
                found[j, 4] + out[4]
            ):
                return False, found, rects
        found[i] = out
    if settings[12] > 0.0 and _off_geometry(found[:, 1:3].copy(), found[:, 4], ref, settings[13]):
        return False, found, rects
    return True, found, rects
