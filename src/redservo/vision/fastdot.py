"""The fast path of the image dot tracker: one compiled call per dot in a small window.

:class:`~redservo.vision.tracking.ImageDotTracker` first looks for a tracked dot with
:func:`window_blob`: the window of half-size ``size / 2 + pad + 4 + FAST_SLACK_PX``
pixels around the dot's prediction, thresholded at the first of its own gray levels
(``b + 0.5 (L - b)``), searched by :func:`redservo.kernels.blob.window_dot` (labelling,
the tracker's tests and the clipped centroid as moment sums). The kernel only accepts;
whatever it cannot decide (the dot is farther than ``FAST_SLACK_PX`` from its
prediction, a lighting gradient across the ring, a blob near a shape limit, a dot
merged with another) returns None and the tracker runs its reference search
(:meth:`~redservo.vision.tracking.ImageDotTracker._search`) unchanged, so the fast path
changes the cost, not what is tracked.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.kernels._jit import COMPILED
from redservo.kernels.blob import FOUND, window_dot
from redservo.kernels.blob_frame import track_frame
from redservo.vision.blobs import Blob, _disc
from redservo.vision.dots import DotTrack
from redservo.vision.lazyframe import LazyFrame

if TYPE_CHECKING:  # pragma: no cover
    from redservo.vision.tracking import ImageDotTracker, _Dot

__all__ = ["FAST_SLACK_PX", "similarity_prediction", "track_tracked", "window_blob"]

FAST_SLACK_PX = 3.0
"""How far (pixels) a dot may be from its prediction and still be found on the fast path."""


@lru_cache(maxsize=16)
def _discs(p: int) -> NDArray[np.uint8]:
    """(2, D, D) the discs of radius ``p`` and ``p + 2`` (pixels), zero-padded to one size."""
    size = 2 * (p + 2) + 1
    out = np.zeros((2, size, size), np.uint8)
    out[0, 2:-2, 2:-2] = _disc(p)
    out[1] = _disc(p + 2)
    return out


_NO_PARTS = (
    np.zeros((1, 1), np.float32),
    np.zeros((1, 1), np.float32),
    np.zeros(2, np.int64),
    0.0,
    np.zeros((0, 5), np.int64),
    np.zeros(0, np.float32),
    np.zeros((1, 1), np.float32),
    False,
)
"""Frame parts of an image given whole (:func:`track_tracked` composes nothing)."""


def track_tracked(tracker: ImageDotTracker, img: Any, moves: FloatArray) -> DotTrack | None:
    """Every dot of ``tracker`` found in ``img`` by one compiled call, when all were found
    in the last frame (:func:`redservo.kernels.blob_frame.track_frame`, compiled only: its
    geometry check is Python's complex arithmetic with libm's ``hypot``, as numba calls it,
    where plain Python's ``math.hypot`` rounds otherwise): the dots updated as
    :meth:`~redservo.vision.tracking.ImageDotTracker.update` would and its result, or None
    and nothing changed (the caller runs its update). ``moves``: (N, 2) pixels."""
    dots = tracker._dots
    if not COMPILED or any(d.lost for d in dots):  # plain Python: hypot is not libm's
        return None
    state = np.array([(*d.uv.tolist(), d.level, d.background, d.area, d.size) for d in dots])
    if not math.isfinite(float(np.add.reduce(state, None)) + float(np.add.reduce(moves, None))):
        return None  # a NaN or inf (or so large a sum: the update decides, as for a NaN)
    lim = tracker.shape
    settings = np.array(
        [
            max(math.ceil(tracker.pad_px), 1),
            FAST_SLACK_PX,
            tracker.max_jump_px,
            float(tracker.polarity == "bright"),
            tracker.min_size_px,
            tracker.max_size_px,
            tracker.size_precision**2,
            tracker.pad_px,
            *((0.0, 0.0, 0.0, 0.0) if lim is None else (1.0, *lim)),
            float(tracker._ref is not None),
            tracker.geometry_tol,
        ]
    )
    lazy = isinstance(img, LazyFrame)
    if lazy:
        p = img.parts
        gain = _NO_PARTS[6] if p.gain is None else p.gain
        parts = (p.bgb, p.field, p.offset, p.sigma, p.boxes, p.deltas, gain, p.gain is not None)
        pix = img.pixels
    else:
        parts, pix = _NO_PARTS, np.ascontiguousarray(img)
    ref = state[:, :2] if tracker._ref is None else tracker._ref
    ok, found, rects = track_frame(
        pix,
        lazy,
        *parts,
        state,
        np.ascontiguousarray(moves, dtype=float),
        settings,
        _discs(int(settings[0])),
        ref,
    )
    if lazy:  # the windows composed are the frame's pixels now
        img._done.extend(tuple(r) for r in rects.tolist() if r[0] < r[1])
    if not ok:
        return None
    uv = found[:, 1:3].copy()
    rows, vel = uv.copy(), uv - state[:, :2]  # the dots' own arrays: rows never changed
    levels = found[:, 5:7].copy()
    for d, out, new, v, lv in zip(dots, found.tolist(), rows, vel, levels):
        d.vel, d.uv = v, new
        d.level, d.background = lv[0], lv[1]
        d.area, d.size = float(int(out[3])), float(int(out[4]))
    tracker._ref = uv
    tracker._ref_c = [complex(x, y) for x, y in uv.tolist()]
    n = len(dots)
    return DotTrack(uv.copy(), np.ones(n, bool), np.zeros(n, int), n, (), ("",) * n)


def window_blob(
    tracker: ImageDotTracker,
    img: NDArray[np.uint8],
    d: _Dot,
    pred: FloatArray,
    gate: float,
    taken: list[tuple[FloatArray, float]],
) -> Blob | None:
    """The dot ``d``'s blob near ``pred`` (pixels) on the fast path, or None (module docstring)."""
    if not (math.isfinite(d.level) and math.isfinite(d.background) and math.isfinite(d.size)):
        return None
    p = max(math.ceil(tracker.pad_px), 1)
    lim = tracker.shape
    params = np.array(
        [
            pred[0],
            pred[1],
            0.5 * d.size + p + 4.0 + FAST_SLACK_PX,
            gate,
            d.background + 0.5 * (d.level - d.background),
            float(tracker.polarity == "bright"),
            tracker.min_size_px,
            tracker.max_size_px,
            tracker.size_precision**2,
            d.area,
            tracker.pad_px,
            *((0.0, 0.0, 0.0, 0.0) if lim is None else (1.0, *lim)),
        ]
    )
    if isinstance(img, LazyFrame):  # compute the kernel's window first (its arithmetic)
        half = params[2]
        r0, c0 = max(int(pred[1] - half), 0), max(int(pred[0] - half), 0)
        img.region(r0, int(pred[1] + half) + 1, c0, int(pred[0] + half) + 1)
        img = img.pixels
    out = window_dot(img, params, _discs(p))
    if out[0] != FOUND:
        return None
    size = float(out[4])
    for other, other_size in taken:
        if math.hypot(out[1] - other[0], out[2] - other[1]) < 0.5 * (other_size + size):
            return None  # merged with a dot found before: the reference search decides
    return Blob((float(out[1]), float(out[2])), int(out[3]), int(size), out[5], out[6])


def similarity_prediction(
    ref: list[complex], cur: list[complex], found: list[int]
) -> tuple[list[complex], float]:
    """Every dot's position ``u + i v`` (pixels) from the dots ``found`` now at ``cur``: the
    similarity (a translation with one dot) mapping their reference positions ``ref`` (all
    N dots) onto them, and the predicted target's spread (RMS distance from its mean, pixels).
    Plain complex arithmetic: a handful of dots, several times per frame."""
    if len(found) == 1:
        a, b = 1.0 + 0j, cur[0] - ref[found[0]]
    else:
        r0, c0 = sum(ref[i] for i in found) / len(found), sum(cur) / len(found)
        dr = [ref[i] - r0 for i in found]
        num = sum(d.conjugate() * (c - c0) for d, c in zip(dr, cur))
        a = num / max(sum(abs(d) ** 2 for d in dr), 1e-12)
        b = c0 - a * r0
    z = [a * r + b for r in ref]
    mean = sum(z) / len(z)
    return z, math.sqrt(sum(abs(v - mean) ** 2 for v in z) / len(z))
