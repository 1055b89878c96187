"""One task term measured in a rendered image: detector settings and per-term tracking state.

Used by :class:`~redservo.vision.sensor.ImageSensor`. Dots are tracked in the image
itself by :class:`~redservo.vision.tracking.ImageDotTracker` (:func:`dot_tracker`,
:func:`track_dots`): each dot with its own gray-level range, learnt from the image,
so that a lighting gradient, which moves every level, does not lose it; the whole-image
blob count of the notes (:func:`rendered_dots`) and the sphere's threshold follow from
the renderer's gray levels (:func:`gray_threshold`). Spheres are tracked by their last
centre, lines by a constant-velocity prediction of ``(ρ, θ)`` and the sign of their
edges, learnt on the first frame.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import GeometryError
from redservo.vision.depth import DepthPolicy, estimate_inv_depth
from redservo.vision.dots import DotDetection, DotTrack, binarize, detect_dots
from redservo.vision.ellipse import EllipseMethod, detect_ellipse
from redservo.vision.lazyframe import pixels
from redservo.vision.lines import orient_like, refine_line
from redservo.vision.optics import require_cv2
from redservo.vision.pnp import pose_term_depth, set_dots
from redservo.vision.render import Renderer, RenderOptions
from redservo.vision.tracking import ImageDotTracker

if TYPE_CHECKING:  # pragma: no cover
    from redservo.features import SphereFeature
    from redservo.task import VisualTask

__all__ = [
    "TermState",
    "count_dot_blobs",
    "dot_tracker",
    "flat_field",
    "gray_threshold",
    "measure_lines",
    "measure_sphere",
    "rendered_dots",
    "track_dots",
]


@dataclass
class TermState:
    """Detection state of one task term between frames."""

    kind: str
    """Its feature kind's name (``"point"``, ``"sphere"``, ...; :mod:`redservo.features.kinds`)
    or ``"tag"``."""
    dots: NDArray[np.int_] = field(default_factory=lambda: np.zeros(0, dtype=int))
    """Indices of the term's dots in the sensor's dot tracker."""
    s: FloatArray | None = None
    """Last measured (or coasted) value."""
    prev_s: FloatArray | None = None
    """The value before."""
    uv: tuple[float, float] | None = None
    """Last ellipse centre (pixels)."""
    signs: list[float] = field(default_factory=list)
    """Edge sign of each line (0 = not known yet)."""
    lost: int = 0
    """Consecutive frames without a detection."""
    lost_dots: bool = False
    """Some of the term's dots were not found in this frame."""
    inv_depth: FloatArray | None = None
    """Last inverse-depth parameters."""
    pose: FloatArray | None = None
    """The point set's last PnP pose ``cMo`` (4, 4; ``depth = "pose"``), the next one's start."""
    gain: float | None = None
    """Light's gain at a sphere (:func:`measure_sphere`; None = not measured yet)."""
    target: str = ""
    """The name of the object it observes."""

    @property
    def on_dots(self) -> bool:
        """Whether it is measured on the tracked dots (:func:`redservo.vision.measure.dots_term`)."""
        return bool(self.dots.size)


def gray_threshold(level: float, background: float, others: list[float], span: float) -> float:
    """Midway between ``level`` and the nearest gray level on the background side.

    Args:
        level: The object's gray level.
        background: The background's gray level.
        others: Gray levels of the other kinds of objects.
        span: How far the background strays from its level (texture), gray levels.
    """
    bright = level > background
    near = [background + (span if bright else -span)]
    near += [o for o in others if (background < o < level if bright else level < o < background)]
    return 0.5 * (level + (max(near) if bright else min(near)))


def _span(opt: RenderOptions) -> float:
    return 3.0 * opt.texture_amplitude if opt.texture else 0.0


def rendered_dots(image: NDArray[np.uint8], opt: RenderOptions) -> DotDetection:
    """The dots of a rendered image, with thresholds and sizes from the render options.

    The image is first divided by its local background level relative to the options'
    (:func:`flat_field`), so that the gray levels' threshold holds under a lighting
    gradient too.
    """
    lv = opt.levels
    thr = gray_threshold(lv.point, opt.background, [lv.sphere, lv.cylinder, lv.line], _span(opt))
    lo, hi, pad = _dot_sizes(opt)
    return detect_dots(
        flat_field(image, opt),
        threshold=thr,
        polarity="bright" if lv.point > opt.background else "dark",
        min_size_px=lo,
        max_size_px=hi,
        pad_px=pad,
    )


def flat_field(image: NDArray[np.uint8], opt: RenderOptions) -> NDArray[np.uint8]:
    """``image`` with its lighting brought back to the options' background level.

    Light multiplies every gray level, so ``I · background / B`` with ``B`` the local
    background level (the image, box-blurred 5 × 5 against its noise, opened by a square
    wider than a dot for bright dots, closed for dark ones: what is left without the dots)
    restores the rendered levels wherever the background shows: the dots' threshold
    holds under a lighting gradient. Regions brighter than the background (a sphere)
    are their own ``B`` and come out at most at their own level. Unchanged when the
    background level is 0 (no light to divide by).
    """
    if opt.background <= 0.0:
        return image
    cv2 = require_cv2()
    side = 2 * int(np.ceil(opt.levels.dot_radius_px + 3.0 * opt.blur_px)) + 3
    kernel = np.ones((side, side), np.uint8)
    op = cv2.MORPH_OPEN if opt.levels.point > opt.background else cv2.MORPH_CLOSE
    local = cv2.max(cv2.morphologyEx(cv2.blur(image, (5, 5)), op, kernel), 1)
    out: NDArray[np.uint8] = cv2.divide(image, local, scale=float(opt.background))
    return out  # rounded and saturated to 0-255


def _dot_sizes(opt: RenderOptions) -> tuple[float, float, float]:
    """Sizes (pixels) of a rendered dot's blob: smallest and largest bounding box, and the
    margin of the centroid's support."""
    R = opt.levels.dot_radius_px
    return max(2.0, R), 2.0 * R + 4.0 + 6.0 * opt.blur_px, max(2.5, 3.0 * opt.blur_px + 1.0)


def dot_gate_px(opt: RenderOptions) -> float:
    """The dot tracker's gate (pixels): the largest distance of a dot from its
    constant-velocity prediction, ``25 + 3 blur_px``."""
    return 25.0 + 3.0 * opt.blur_px


def dot_tracker(n_dots: int, opt: RenderOptions, max_lost_frames: int) -> ImageDotTracker:
    """The tracker of ``n_dots`` rendered dots: sizes from the render options, a motion of
    up to :func:`dot_gate_px` pixels per frame after the constant-velocity prediction."""
    lo, hi, pad = _dot_sizes(opt)
    return ImageDotTracker(
        n_dots,
        polarity="bright" if opt.levels.point > opt.background else "dark",
        max_jump_px=dot_gate_px(opt),
        max_lost_frames=max_lost_frames,
        min_size_px=lo,
        max_size_px=hi,
        pad_px=pad,
    )


def track_dots(
    tracker: ImageDotTracker,
    image: NDArray[np.uint8],
    opt: RenderOptions,
    start_uv: FloatArray | None,
    notes: list[str],
    shift: FloatArray | None = None,
) -> DotTrack:
    """Track the dots into ``image`` (from ``start_uv``, pixels, on a first frame; then with
    the predicted image motion ``shift`` (N, 2) pixels of each dot, if given).

    Appends to ``notes`` the dots lost in this frame with their reasons
    (:data:`~redservo.vision.tracking.LOSS_REASONS`) and, on the first frame and on a frame
    where a dot was lost (where it says why), the whole-image blob count
    (:func:`count_dot_blobs`) when it differs from the number of dots: a frame where every
    dot was found is not counted (a pass over the whole image, which ``image``, a
    :class:`~redservo.vision.lazyframe.LazyFrame`, then never computes).
    """
    if start_uv is not None:
        track = tracker.start(image, start_uv)
    else:
        track = tracker.update(image, shift)
    everyone = start_uv is None and bool(track.detected.all())
    n_blobs, n_border = (tracker.n_dots, 0) if everyone else count_dot_blobs(pixels(image), opt)
    n = tracker.n_dots
    if n_blobs != n:
        notes.append(f"found {n_blobs} dot blob(s), expected {n}")
    missing = np.flatnonzero(~track.detected)
    if missing.size:
        why = ", ".join(f"{int(j)} ({track.reasons[j]})" for j in missing)
        notes.append(f"dot(s) {why} not found")
    if n_border:
        notes.append(f"{n_border} blob(s) cut by the image border")
    return track


def count_dot_blobs(image: NDArray[np.uint8], opt: RenderOptions) -> tuple[int, int]:
    """How many blobs of a dot's size :func:`rendered_dots` would consider: ``(inside,
    cut by the image border)``, without measuring them (a quarter of the cost)."""
    cv2 = require_cv2()
    lv = opt.levels
    thr = gray_threshold(lv.point, opt.background, [lv.sphere, lv.cylinder, lv.line], _span(opt))
    bright = lv.point > opt.background
    mask, _ = binarize(flat_field(image, opt), thr, "bright" if bright else "dark")
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    lo, hi, pad = _dot_sizes(opt)
    H, W = image.shape
    m = int(np.ceil(pad)) + 2
    inside = border = 0
    for cnt in contours:
        x, y, bw, bh = cv2.boundingRect(cnt)
        if lo <= max(bw, bh) <= hi:
            cut = x - m < 0 or y - m < 0 or x + bw + m > W or y + bh + m > H
            border += cut
            inside += not cut
    return inside, border


def measure_sphere(
    image: NDArray[np.uint8],
    renderer: Renderer,
    st: TermState,
    feature: SphereFeature,
    method: EllipseMethod,
    truth: FloatArray | None,
) -> tuple[FloatArray | None, str]:
    """The sphere's ``s`` (per its variant) near its last centre, or None and why.

    The threshold is the gray levels' one (:func:`gray_threshold`) times the light's gain at
    the sphere, the median gray level of its centre over its rendered level (on the first
    frame at its true centre, then at its last measured one): a lighting gradient that dims
    the sphere below the fixed threshold does not lose it.
    """
    opt = renderer.options
    lv = opt.levels
    if st.uv is None and truth is not None:
        uv0 = renderer.optics.to_pixel(truth[:2])
        st.uv = (float(uv0[0]), float(uv0[1]))
    if st.gain is None:
        st.gain = 1.0 if st.uv is None else _gain(image, st.uv, 2.0, lv.sphere)
    thr = st.gain * gray_threshold(lv.sphere, opt.background, [lv.cylinder], _span(opt))
    meas, why = detect_ellipse(
        image,
        renderer.optics,
        threshold=float(np.clip(thr, 1.0, 254.0)),
        polarity="bright" if lv.sphere > opt.background else "dark",
        near_uv=st.uv,
        method=method,
        pad_px=3.0 + 3.0 * opt.blur_px,
        blur_px=opt.blur_px,
    )
    if meas is None:
        return None, why
    st.uv = meas.uv
    r_px = 0.4 * np.sqrt(max(meas.area, 0.0) / np.pi) * renderer.camera.px
    st.gain = _gain(image, meas.uv, max(float(r_px), 2.0), lv.sphere)
    if feature.variant == "moments":
        return np.array([meas.xc, meas.yc, meas.n20, meas.n11, meas.n02]), ""
    return np.array([meas.xc, meas.yc, meas.area]), ""


def _gain(
    image: NDArray[np.uint8], uv: tuple[float, float], radius_px: float, level: float
) -> float:
    """The light's gain at pixel ``uv``: the median gray level within ``radius_px`` of it over
    ``level`` (the object's rendered level), clipped to [0.5, 2]; 1 outside the image."""
    H, W = image.shape
    u, v, r = float(uv[0]), float(uv[1]), int(np.ceil(radius_px))
    c, w = int(np.floor(u)), int(np.floor(v))
    if level <= 0.0 or not (0 <= c < W and 0 <= w < H):
        return 1.0
    rows = np.arange(max(w - r, 0), min(w + r + 1, H))
    cols = np.arange(max(c - r, 0), min(c + r + 1, W))
    near = (rows[:, None] + 0.5 - v) ** 2 + (cols[None, :] + 0.5 - u) ** 2 <= radius_px**2
    patch = image[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1][near]
    return float(np.clip(np.median(patch) / level, 0.5, 2.0)) if patch.size else 1.0


def measure_lines(
    image: NDArray[np.uint8], renderer: Renderer, st: TermState, truth: FloatArray | None
) -> tuple[FloatArray | None, str]:
    """A cylinder's two limbs or a line, ``(ρ, θ)`` each, oriented like the last value."""
    if st.s is None:
        if truth is None:
            return None, "not visible on the first frame"
        pred = truth.copy()
    elif st.prev_s is not None and st.lost == 0:
        pred = 2.0 * st.s - st.prev_s  # constant velocity
    else:
        pred = st.s.copy()
    ref = pred if st.s is None else st.s
    n_lines = pred.shape[0] // 2
    if not st.signs:
        st.signs = [0.0] * n_lines
    opt = renderer.options
    out = np.empty_like(pred)
    for k in range(n_lines):
        meas, why = refine_line(
            image,
            renderer.optics,
            float(pred[2 * k]),
            float(pred[2 * k + 1]),
            mode="edge" if st.kind == "cylinder" else "ridge",
            sign=st.signs[k],
            blur_px=opt.blur_px,
            width_px=opt.levels.line_width_px,
        )
        if meas is None:
            return None, f"line {k + 1}: {why}"
        st.signs[k] = meas.sign
        rho, theta = orient_like(meas.rho, meas.theta, float(ref[2 * k]), float(ref[2 * k + 1]))
        out[2 * k : 2 * k + 2] = (rho, theta)
    return out, ""


def term_inv_depths(
    policy: DepthPolicy,
    task: VisualTask,
    terms: list[TermState],
    truth_d: list[FloatArray | None],
    dots: tuple[Mapping[str, FloatArray], NDArray[np.bool_], FloatArray],
    tried: dict[str, tuple[int, int] | None] | None = None,
) -> tuple[FloatArray, ...] | None:
    """Each term's inverse-depth parameters under the depth ``policy``
    (:mod:`redservo.vision.depth`), kept in ``TermState.inv_depth`` (the dots' predicted motion
    uses them, :mod:`redservo.vision.motion`); None while a term has none yet.

    ``truth_d``: the true parameters per term where measured; ``dots``: the point sets, the
    dots detected this frame and every dot's normalized position (N, 2); ``tried``: filled
    with this frame's PnP solves by point set (``depth = "pose"``,
    :func:`~redservo.vision.pnp.pose_term_depth`)."""
    if policy == "desired":
        assert task.inv_depth_star is not None  # checked when the sensor plans the task
        for st, star in zip(terms, task.inv_depth_star):
            st.inv_depth = star
        return task.inv_depth_star
    sets, detected, xy = dots
    out = []
    poses: dict[Any, FloatArray | None] = {}  # one PnP solve per point set and frame
    for i, (term, st) in enumerate(zip(task.terms, terms)):
        if policy == "pose":
            d = pose_term_depth(task, i, st, sets, detected, xy, poses, tried)
        else:
            d = truth_d[i]
        if policy == "estimated" and st.s is not None and st.kind != "tag":
            kw: dict[str, Any] = {}
            if st.on_dots:
                name = term.target
                kw = {"set_points": sets[name], "set_xy": set_dots(sets, detected, name, xy)}
            try:
                d = estimate_inv_depth(term.feature, st.s, **kw)
            except GeometryError:
                d = None  # keep the last estimate
        if d is not None:
            st.inv_depth = d
        if st.inv_depth is None:
            return None
        out.append(st.inv_depth)
    return tuple(out)
