"""One task term measured in a rendered image: detector settings and per-term tracking state.

Used by :class:`~redservo.vision.sensor.ImageSensor`. The detectors' thresholds
follow from the renderer's gray levels (:func:`gray_threshold`); spheres are
tracked by their last centre, lines by a constant-velocity prediction of
``(ρ, θ)`` and the sign of their edges, learnt on the first frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.features import SphereFeature
from redservo.vision.dots import DotDetection, detect_dots
from redservo.vision.ellipse import EllipseMethod, detect_ellipse
from redservo.vision.lines import orient_like, refine_line
from redservo.vision.render import Renderer, RenderOptions

__all__ = ["TermState", "gray_threshold", "measure_lines", "measure_sphere", "rendered_dots"]


@dataclass
class TermState:
    """Detection state of one task term between frames."""

    kind: str
    """``"point"``, ``"moments"``, ``"sphere"``, ``"cylinder"`` or ``"line"``."""
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
    """The dots of a rendered image, with thresholds and sizes from the render options."""
    lv = opt.levels
    thr = gray_threshold(lv.point, opt.background, [lv.sphere, lv.cylinder, lv.line], _span(opt))
    R = lv.dot_radius_px
    return detect_dots(
        image,
        threshold=thr,
        polarity="bright" if lv.point > opt.background else "dark",
        min_size_px=max(2.0, R),
        max_size_px=2.0 * R + 4.0 + 6.0 * opt.blur_px,
        pad_px=max(2.5, 3.0 * opt.blur_px + 1.0),
    )


def measure_sphere(
    image: NDArray[np.uint8],
    renderer: Renderer,
    st: TermState,
    feature: SphereFeature,
    method: EllipseMethod,
    truth: FloatArray | None,
) -> tuple[FloatArray | None, str]:
    """The sphere's ``s`` (per its variant) near its last centre, or None and why."""
    opt = renderer.options
    lv = opt.levels
    if st.uv is None and truth is not None:
        uv0 = renderer.optics.to_pixel(truth[:2])
        st.uv = (float(uv0[0]), float(uv0[1]))
    meas, why = detect_ellipse(
        image,
        renderer.optics,
        threshold=gray_threshold(lv.sphere, opt.background, [lv.cylinder], _span(opt)),
        polarity="bright" if lv.sphere > opt.background else "dark",
        near_uv=st.uv,
        method=method,
        pad_px=3.0 + 3.0 * opt.blur_px,
        blur_px=opt.blur_px,
    )
    if meas is None:
        return None, why
    st.uv = meas.uv
    if feature.variant == "moments":
        return np.array([meas.xc, meas.yc, meas.n20, meas.n11, meas.n02]), ""
    return np.array([meas.xc, meas.yc, meas.area]), ""


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
