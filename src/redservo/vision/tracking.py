"""Dot tracking in the images: per-dot gray levels and sizes, re-acquisition, typed losses.

:class:`ImageDotTracker` follows the method of ViSP's ``vpDot2`` (its published
description, not its code): each dot is searched in a window around its
prediction with its *own* gray-level range, and its area must stay close to the
last one. Per frame, for each dot:

1. **Prediction**: constant velocity from its last two positions. A lost dot
   (not found in the last frame) is predicted from the *geometry* of the dots
   found in this frame when there are any: the similarity (scale, rotation,
   translation; a translation with one dot) that maps their positions at the last
   frame where all dots were found onto their positions now, applied to the lost
   dot's position then. Else it coasts at its last velocity.
2. **Search window**: a square of half-size ``max_jump_px + size + pad_px + 3``
   around the prediction, which grows by ``window_growth`` x that for each frame
   the dot has been lost (capped at the image) when it has no geometric
   prediction (with one: ``gate + size + pad_px + 3``, gate below). A lost dot
   coasts at its last velocity for ``max_lost_frames`` frames, then stays put. A
   window overlapping the image is searched even if its centre is outside; a dot
   not found with its prediction outside the image is ``"out_of_image"``.
3. **Gray-level range**: with ``L`` the dot's plateau and ``b`` its background at
   the last frame it was found, the window is thresholded at
   ``b + f (L - b)`` for ``f = 0.5, 0.65, 0.8, 0.9`` in turn, then at the window's
   Otsu level (when the window spans half the dot's contrast: not in pure
   background, whose noise Otsu would split), until a blob passes the tests: the higher levels separate a dot
   from a background brighter than the midway level (ViSP's narrow gray-level
   range around the dot's mean). Dark dots use the mirrored range.
4. **Tests**, in order, on the components nearest the prediction (within the
   gate: ``max_jump_px + size`` for a tracked dot, the window for a lost one,
   ``max(2 size, geometry_tol x target size)`` around the geometric prediction
   for a lost dot with one): the component touches the image border
   (``"at_border"``); it is larger than ``max_size_px`` or its area above
   ``area / size_precision²`` or it reaches the window's edge
   (``"merged_with_background"``); it is smaller than ``min_size_px`` or its area
   below ``size_precision² x area`` (half that at the higher levels, where a dot
   is thinner) (``"too_small"``); its shape (``"bad_shape"``, :mod:`redservo.vision.blobs`);
   its centroid and contrast (``"centroid_outside_blob"``, ``"low_contrast"``); it
   is the blob of a dot already found this frame (``"merged_with_dot"``). No
   component at all in the window: ``"out_of_window"``. The reason recorded for a
   lost dot is that of the component nearest its prediction at the first level.
5. **Adaptation**: a found dot's plateau, background and (at the first level)
   area become its references for the next frame.

Tracked dots are handled first, in index order; a tracked dot found farther from
the position the other found dots (two or more) give it than that gate is refused
and searched again as a lost dot (``"off_geometry"`` if not found: a digit or
another blob within ``max_jump_px``); then the lost ones (so that their geometric
prediction uses this frame's positions). The dot order never changes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, ShapeError
from redservo.vision.blobs import Blob, ShapeLimits, components, measure_blob, shape_reason
from redservo.vision.dots import DotTrack, Polarity
from redservo.vision.fastdot import similarity_prediction, track_tracked, window_blob
from redservo.vision.lazyframe import frame_or_array, window
from redservo.vision.optics import require_cv2

__all__ = ["LOSS_REASONS", "ImageDotTracker"]

LOSS_REASONS = (
    "out_of_image",
    "out_of_window",
    "at_border",
    "merged_with_background",
    "too_small",
    "bad_shape",
    "centroid_outside_blob",
    "low_contrast",
    "merged_with_dot",
    "off_geometry",
    "not_started",
)
"""Every reason a dot can be lost for in a frame (module docstring)."""

_LEVELS = (0.5, 0.65, 0.8, 0.9)


@dataclass
class _Dot:
    uv: FloatArray
    vel: FloatArray = field(default_factory=lambda: np.zeros(2))
    level: float = np.nan
    background: float = np.nan
    area: float = np.nan
    size: float = np.nan
    lost: int = 0


@dataclass
class ImageDotTracker:
    """Tracks N dots in the images themselves, in a fixed order (module docstring).

    Attributes:
        n_dots: Number of dots N.
        polarity: ``"bright"`` or ``"dark"`` dots.
        max_jump_px: Largest distance (pixels) between a dot's prediction and its blob.
        max_lost_frames: A dot lost for more consecutive frames is reported gone (it is
            still searched for).
        min_size_px: Smallest bounding-box size (pixels) of a dot.
        max_size_px: Largest bounding-box size (pixels) of a dot.
        pad_px: Margin (pixels) of the centroid's support (>= 3 x the blur σ).
        size_precision: A dot's area must stay within ``[p² a, a / p²]`` of its last
            area ``a`` (ViSP's size precision).
        window_growth: The search window's half-size grows by this fraction of its
            base per frame lost.
        geometry_tol: Gate around a lost dot's geometric prediction, as a fraction of
            the target's size (RMS distance of the dots from their mean).
        shape: Limits of the shape tests; None = no test.
    """

    n_dots: int
    polarity: Polarity = "bright"
    max_jump_px: float = 25.0
    max_lost_frames: int = 3
    min_size_px: float = 2.0
    max_size_px: float = 30.0
    pad_px: float = 2.5
    size_precision: float = 0.6
    window_growth: float = 1.0
    geometry_tol: float = 0.25
    shape: ShapeLimits | None = field(default_factory=ShapeLimits)

    def __post_init__(self) -> None:
        if self.n_dots < 1:
            raise ConfigurationError(f"n_dots must be >= 1, got {self.n_dots}")
        if self.polarity not in ("bright", "dark"):
            raise ConfigurationError(f"polarity must be 'bright' or 'dark', got {self.polarity!r}")
        for name in ("max_jump_px", "pad_px", "window_growth", "geometry_tol"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0.0):
                raise ConfigurationError(f"{name} must be positive, got {getattr(self, name)!r}")
        if not 0.0 < self.size_precision < 1.0:
            raise ConfigurationError(
                f"size_precision must be in (0, 1), got {self.size_precision!r}"
            )
        if not 0.0 < self.min_size_px <= self.max_size_px < np.inf:
            raise ConfigurationError(
                "the dot sizes must be finite with 0 < min_size_px <= max_size_px, got "
                f"{self.min_size_px!r} and {self.max_size_px!r}"
            )
        if self.max_lost_frames < 0:
            raise ConfigurationError(f"max_lost_frames must be >= 0, got {self.max_lost_frames}")
        self._dots: list[_Dot] = []
        self._ref: FloatArray | None = None
        self._ref_c: list[complex] = []  # the same, as complex numbers u + i v

    @property
    def started(self) -> bool:
        """True once :meth:`start` was called."""
        return bool(self._dots)

    def start(self, image: NDArray[np.uint8], uv: ArrayLike) -> DotTrack:
        """Find each dot near its initial position (N, 2) in pixels (NaN = unknown).

        Each dot is the blob nearest its position in a window of half-size
        ``max_size_px + pad_px + 3`` around it thresholded at the window's Otsu level
        ``t``, else at ``t + 0.4 (p - t)`` or ``t + 0.6 (p - t)`` (``p`` the window's
        brightest level after a 3 x 3 mean, darkest for dark dots: a dot on a
        brighter background); its
        gray levels and area become its references. Returns the state, as :meth:`update`.
        """
        img = frame_or_array(image)
        p = np.asarray(uv, dtype=float)
        if p.shape != (self.n_dots, 2):
            raise ShapeError(
                f"initial dot positions must have shape ({self.n_dots}, 2), got {p.shape}"
            )
        self._dots = [_Dot(p[i].copy()) for i in range(self.n_dots)]
        self._ref = None
        half = self.max_size_px + self.pad_px + 3.0
        reasons: list[str] = []
        for d in self._dots:
            if not np.isfinite(d.uv).all():
                d.lost = 1
                reasons.append("not_started")
                continue
            blob, why, _ = self._search(img, d, d.uv, half, 0.5 * self.max_size_px + 2, [])
            reasons.append(why)
            if blob is None:
                d.lost = 1
            else:
                self._accept(d, blob, adapt_area=True)
        return self._state(reasons)

    def update(self, image: NDArray[np.uint8], shift: ArrayLike | None = None) -> DotTrack:
        """Track every dot into ``image`` (H, W) uint8; return the new state.

        Args:
            image: The frame.
            shift: (N, 2) image motion (pixels) of each dot since the last frame, predicted
                by the caller (e.g. from the commanded camera twist and the interaction
                matrix); it replaces the constant-velocity prediction, so that the search
                window follows the predicted motion. A NaN row: no prediction for that dot.
        """
        if not self._dots:
            raise ConfigurationError("ImageDotTracker.update called before start(image, uv)")
        img = frame_or_array(image)
        moves = self._moves(shift)
        fast = track_tracked(self, img, moves)  # every dot at once (the common frame)
        if fast is not None:
            return fast
        reasons = [""] * self.n_dots
        taken: dict[int, tuple[FloatArray, float]] = {}
        before = {i: _copy(d) for i, d in enumerate(self._dots) if d.lost == 0}
        for i in before:
            d = self._dots[i]
            pred = d.uv + moves[i]
            base = self.max_jump_px + d.size + self.pad_px + 3.0
            gate = self.max_jump_px + d.size
            blob: Blob | None = window_blob(self, img, d, pred, gate, list(taken.values()))
            why, first = "", True
            if blob is None:
                blob, why, first = self._search(img, d, pred, base, gate, list(taken.values()))
            reasons[i] = self._finish(i, pred, blob, why, first, taken)
        refused = self._off_geometry(taken)
        for i in refused:
            self._dots[i] = before[i]
            del taken[i]
        found = sorted(taken)
        geo = self._geometry(found)
        for i, d in enumerate(self._dots):
            if i in before and i not in refused:
                continue
            pred = d.uv + moves[i]
            size = d.size if np.isfinite(d.size) else self.max_size_px
            base = self.max_jump_px + size + self.pad_px + 3.0
            half = min(base * (1.0 + self.window_growth * d.lost), float(max(img.shape)))
            gate = half
            if geo is not None:
                pred, spread = np.array([geo[0][i].real, geo[0][i].imag]), geo[1]
                gate = max(2.0 * size, self.geometry_tol * spread)
                half = gate + size + self.pad_px + 3.0  # the geometry is known: no growth
            if not np.isfinite(pred).all():
                reasons[i] = "not_started"
                d.lost += 1
                continue
            blob, why, first = self._search(img, d, pred, half, gate, list(taken.values()))
            reasons[i] = self._finish(i, pred, blob, why, first, taken)
            if i in refused and reasons[i]:
                reasons[i] = "off_geometry"
        if all(d.lost == 0 for d in self._dots):
            self._ref = np.array([d.uv for d in self._dots])
            self._ref_c = [complex(x, y) for x, y in self._ref.tolist()]
        return self._state(reasons)

    def _moves(self, shift: ArrayLike | None) -> FloatArray:
        """Each dot's predicted motion (N, 2) in pixels: ``shift`` where given, else its velocity."""
        if shift is None:
            return np.array([d.vel for d in self._dots])
        s = np.asarray(shift, dtype=float)
        if s.shape != (self.n_dots, 2):
            raise ShapeError(f"shift must have shape ({self.n_dots}, 2) pixels, got {s.shape}")
        total = float(np.add.reduce(s, None))
        if math.isfinite(total):  # the common frame: every dot predicted
            return s.copy()
        if np.isinf(s).any():
            raise ConfigurationError("shift must be finite (NaN = no prediction), got inf")
        vel = np.array([d.vel for d in self._dots])
        return np.where(np.isnan(s).any(axis=1, keepdims=True), vel, s)

    def _off_geometry(self, taken: dict[int, tuple[FloatArray, float]]) -> list[int]:
        """Dots found this frame far from where the other found dots (>= 2) put them."""
        refused = []
        for i in sorted(taken):
            others = [j for j in taken if j != i]
            geo = self._geometry(others) if len(others) >= 2 else None
            if geo is None:
                continue
            size = taken[i][1]
            gate = max(2.0 * size, self.geometry_tol * geo[1])
            if abs(complex(*taken[i][0].tolist()) - geo[0][i]) > gate:
                refused.append(i)
        return refused

    # -- internals ---------------------------------------------------------------------

    def _finish(
        self,
        i: int,
        pred: FloatArray,
        blob: Blob | None,
        why: str,
        first: bool,
        taken: dict[int, tuple[FloatArray, float]],
    ) -> str:
        d = self._dots[i]
        if blob is None:
            d.uv = pred
            d.lost += 1
            if d.lost > self.max_lost_frames:
                d.vel = np.zeros(2)  # stop coasting: the window grows around the last guess
            return why
        old, was_found = d.uv.copy(), d.lost == 0
        self._accept(d, blob, adapt_area=first)
        d.vel = d.uv - old if was_found else np.zeros(2)
        taken[i] = (d.uv.copy(), float(blob.size))
        return ""

    def _accept(self, d: _Dot, blob: Blob, adapt_area: bool) -> None:
        d.uv = np.array(blob.uv, dtype=float)
        d.level, d.background = blob.level, blob.background
        if adapt_area or not np.isfinite(d.area):
            d.area, d.size = float(blob.area), float(blob.size)
        d.lost = 0

    def _geometry(self, found: list[int]) -> tuple[list[complex], float] | None:
        """Every dot's position predicted from the found dots (similarity from the reference)."""
        if self._ref is None or not found:
            return None
        cur = [complex(*self._dots[i].uv.tolist()) for i in found]
        return similarity_prediction(self._ref_c, cur, found)

    def _thresholds(self, d: _Dot, win: NDArray[np.uint8]) -> Iterator[float]:
        """The gray levels to try, in order (module docstring; Otsu computed only if reached)."""
        cv2 = require_cv2()
        known = bool(np.isfinite(d.level) and np.isfinite(d.background))
        if known:
            c = d.level - d.background
            yield from (d.background + f * c for f in _LEVELS)
            smooth = cv2.blur(win, (3, 3))
            if float(smooth.max()) - float(smooth.min()) < 0.5 * abs(c):
                return  # nothing in the window has the dot's contrast: no Otsu split of noise
        otsu = float(cv2.threshold(win, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)[0])
        yield otsu
        if not known:
            smooth = cv2.blur(win, (3, 3))
            top = float(smooth.max() if self.polarity == "bright" else smooth.min())
            yield from (otsu + f * (top - otsu) for f in (0.4, 0.6))

    def _search(
        self,
        img: NDArray[np.uint8],
        d: _Dot,
        centre: FloatArray,
        half: float,
        gate: float,
        taken: list[tuple[FloatArray, float]],
    ) -> tuple[Blob | None, str, bool]:
        """The dot's blob near ``centre`` (pixels): ``(blob, "", first level?)`` or ``(None, why, _)``."""
        H, W = img.shape
        outside = not (0.0 <= centre[0] <= W and 0.0 <= centre[1] <= H)
        c0, c1 = max(int(centre[0] - half), 0), min(int(centre[0] + half) + 1, W)
        r0, r1 = max(int(centre[1] - half), 0), min(int(centre[1] + half) + 1, H)
        if c1 - c0 < 2 or r1 - r0 < 2:
            return None, "out_of_image", False
        win = window(img, r0, r1, c0, c1)
        bright = self.polarity == "bright"
        reason = ""
        for j, thr in enumerate(self._thresholds(d, win)):
            mask = (win > thr) if bright else (win < thr)
            _, labels, stats = components(mask.astype(np.uint8))
            centres = stats[1:, :2] + 0.5 * stats[1:, 2:4] + [c0, r0]
            dist = np.hypot(*(centres - centre).T)
            for rank, k in enumerate(np.argsort(dist) + 1):
                if dist[k - 1] > gate + 0.5 * max(stats[k, 2], stats[k, 3]):
                    break
                where = (c0, r0, W, H)
                why, blob = self._check(win, labels, stats, k, where, j, taken, d.area)
                if blob is not None:
                    return blob._replace(uv=(blob.uv[0] + c0, blob.uv[1] + r0)), "", j == 0
                if rank == 0 and not reason:
                    reason = why
        return None, "out_of_image" if outside else (reason or "out_of_window"), False

    def _check(
        self,
        win: NDArray[np.uint8],
        labels: NDArray[np.int32],
        stats: NDArray[np.int32],
        k: int,
        where: tuple[int, int, int, int],
        level: int,
        taken: list[tuple[FloatArray, float]],
        ref_area: float,
    ) -> tuple[str, Blob | None]:
        """``("", blob)`` if component ``k`` of the window is the dot, else ``(reason, None)``."""
        known = bool(np.isfinite(ref_area))
        x, y, w, h, area = (int(a) for a in stats[k])
        c0, r0, W, H = where
        wh, ww = win.shape
        if x + c0 == 0 or y + r0 == 0 or x + c0 + w == W or y + r0 + h == H:
            return "at_border", None
        p2 = self.size_precision**2
        at_edge = x == 0 or y == 0 or x + w == ww or y + h == wh
        if max(w, h) > self.max_size_px or at_edge or (known and area > ref_area / p2):
            return "merged_with_background", None
        low = p2 * ref_area * (1.0 if level == 0 else 0.5) if known else 0.0
        if max(w, h) < self.min_size_px or area < low:
            return "too_small", None
        if self.shape is not None and shape_reason(labels[y : y + h, x : x + w] == k, self.shape):
            return "bad_shape", None
        bright = self.polarity == "bright"
        blob, why = measure_blob(win, labels, k, (x, y, w, h), self.pad_px, bright)
        if blob is None:
            return why, None
        uv = np.array([blob.uv[0] + c0, blob.uv[1] + r0])
        for other, size in taken:
            if np.hypot(*(uv - other)) < 0.5 * (size + blob.size):
                return "merged_with_dot", None
        return "", blob

    def _state(self, reasons: list[str]) -> DotTrack:
        uv = np.array([d.uv for d in self._dots], dtype=float)
        detected = np.array([d.lost == 0 for d in self._dots])
        lost = np.array([d.lost for d in self._dots], dtype=int)
        gone = tuple(int(i) for i in np.flatnonzero(lost > self.max_lost_frames))
        return DotTrack(uv, detected, lost, int(detected.sum()), gone, tuple(reasons))


def _copy(d: _Dot) -> _Dot:
    """A shallow copy of ``d`` (its arrays are replaced, never changed in place)."""
    return _Dot(d.uv, d.vel, d.level, d.background, d.area, d.size, d.lost)
