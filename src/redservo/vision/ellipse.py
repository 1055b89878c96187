"""Ellipse of a sphere's image: centre, area and normalized centred moments.

:func:`detect_ellipse` picks one blob of a thresholded image (the one nearest
a predicted centre, else the largest) and measures, in *undistorted normalized*
coordinates, ``xc, yc``, the area ``a`` and ``n_ij = μ_ij / a`` — the values of
:func:`redservo.features.sphere.sphere_ellipse`. Two methods:

Every component counts, nested ones too (``cv2.RETR_CCOMP``'s outer
boundaries); with a prediction, the smallest blob whose box holds it is taken.

* ``"moments"`` (default, sub-pixel): the region's coverage is estimated per
  pixel, ``w = (I - b)/(L - b)`` with ``b`` the median gray level of the ring
  around the blob and ``L`` the median inside it (eroded), over the blob grown
  by ``pad_px``; ``w`` is clipped to [-0.5, 1.5] (limits the effect of brighter
  dots drawn on top, not of the noise). The moments are sums over the pixels,
  each at its undistorted normalized coordinates with its own area (so radial
  distortion is undone exactly). Two corrections make them those of the sharp
  region: a pixel sampled at its centre misses the variance of its box, 1/12
  px² per axis (added), and a Gaussian blur of σ pixels adds σ² per axis
  (``blur_px``, subtracted; 0 for a real camera of unknown blur);
* ``"contour"``: ``cv2.fitEllipse`` on the blob's outer contour (pixel centres,
  mapped to undistorted coordinates) with both semi-axes lengthened by half a
  pixel (the contour runs through the boundary pixels' centres, half a pixel
  inside the thresholded edge). Faster, less accurate (see docs/vision.md).

An ellipse ``(xc, yc)`` with semi-axes ``A >= B`` at angle ``φ`` has
``n20 = (A² cos²φ + B² sin²φ)/4``, ``n02 = (A² sin²φ + B² cos²φ)/4``,
``n11 = (A² - B²) sin φ cos φ / 4`` and area ``π A B``.

A blob touching the image border is refused (its moments would be those of the
visible part): the result is None with the reason.
"""

from __future__ import annotations

from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo.errors import ConfigurationError
from redservo.vision.dots import Polarity, binarize
from redservo.vision.optics import Optics, require_cv2

__all__ = [
    "EllipseMeasurement",
    "EllipseMethod",
    "detect_ellipse",
    "ellipse_moments",
    "pixel_ellipse",
]

EllipseMethod = Literal["moments", "contour"]


class EllipseMeasurement(NamedTuple):
    """An ellipse in undistorted normalized image coordinates."""

    xc: float
    yc: float
    area: float
    """Area (normalized units²)."""
    n20: float
    n11: float
    n02: float
    uv: tuple[float, float]
    """Centre in pixels (distorted image), for tracking."""


def ellipse_moments(A: float, B: float, phi: float) -> tuple[float, float, float]:
    """``(n20, n11, n02)`` of an ellipse with semi-axes ``A, B`` and major-axis angle ``phi`` (rad)."""
    c, s = np.cos(phi), np.sin(phi)
    return (
        float((A * A * c * c + B * B * s * s) / 4.0),
        float((A * A - B * B) * s * c / 4.0),
        float((A * A * s * s + B * B * c * c) / 4.0),
    )


def _pick(
    contours: list[NDArray[np.int32]], near_uv: ArrayLike | None, min_area_px: float
) -> NDArray[np.int32] | None:
    cv2 = require_cv2()
    best, best_key = None, np.inf
    near = None if near_uv is None else np.asarray(near_uv, dtype=float)
    for cnt in contours:
        area = cv2.contourArea(cnt)
        if area < min_area_px:
            continue
        if near is None:
            key = -area
        else:
            x, y, w, h = cv2.boundingRect(cnt)
            inside = x <= near[0] <= x + w and y <= near[1] <= y + h
            # The innermost blob whose box holds the prediction (a bright sphere in a
            # dark region of a bright scene: not the scene), else the nearest.
            key = (
                area if inside else 1e12 + float(np.hypot(x + w / 2 - near[0], y + h / 2 - near[1]))
            )
        if key < best_key:
            best, best_key = cnt, key
    return best


def _moments_method(
    image: NDArray[np.uint8],
    cnt: NDArray[np.int32],
    optics: Optics,
    polarity: Polarity,
    pad_px: float,
    blur_px: float,
) -> EllipseMeasurement | None:
    cv2 = require_cv2()
    H, W = image.shape
    x, y, w, h = cv2.boundingRect(cnt)
    p = int(np.ceil(pad_px))
    r0, r1, c0, c1 = (
        max(y - p - 2, 0),
        min(y + h + p + 2, H),
        max(x - p - 2, 0),
        min(x + w + p + 2, W),
    )
    roi = image[r0:r1, c0:c1].astype(np.float32)
    inside = np.zeros(roi.shape, np.uint8)
    cv2.drawContours(inside, [cnt], -1, 255, thickness=-1, offset=(-c0, -r0))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * p + 1, 2 * p + 1))
    support = cv2.dilate(inside, kernel) > 0
    core = cv2.erode(inside, kernel) > 0
    ring = ~support
    if not ring.any():
        return None
    b = float(np.median(roi[ring]))
    L = float(np.median(roi[core])) if core.any() else float(roi[inside > 0].max())
    sign = 1.0 if polarity == "bright" else -1.0
    if sign * (L - b) <= 1.0:
        return None
    wts = np.clip((roi - b) / (L - b), -0.5, 1.5) * support
    rows, cols = slice(r0, r1), slice(c0, c1)
    xs, ys = optics.grid(rows, cols)
    dA = wts * optics.pixel_area(rows, cols)
    m00 = float(dA.sum())
    if m00 <= 0.0:
        return None
    xc = float((dA * xs).sum()) / m00
    yc = float((dA * ys).sum()) / m00
    dx, dy = xs - xc, ys - yc
    cam = optics.camera
    corr = 1.0 / 12.0 - blur_px * blur_px  # px², see the module docstring
    n20 = float((dA * dx * dx).sum()) / m00 + corr / cam.px**2
    n11 = float((dA * dx * dy).sum()) / m00
    n02 = float((dA * dy * dy).sum()) / m00 + corr / cam.py**2
    uv = optics.to_pixel(np.array([xc, yc]))
    return EllipseMeasurement(xc, yc, m00, n20, n11, n02, (float(uv[0]), float(uv[1])))


def _contour_method(cnt: NDArray[np.int32], optics: Optics) -> EllipseMeasurement | None:
    cv2 = require_cv2()
    if cnt.shape[0] < 5:
        return None
    cam = optics.camera
    xy = optics.to_normalized(cnt.reshape(-1, 2).astype(float) + 0.5)
    und = (xy * [cam.px, cam.py] + [cam.u0, cam.v0]).astype(np.float32)  # undistorted pixels
    (cu, cv), (d1, d2), angle = cv2.fitEllipse(und)
    uv = optics.to_pixel(np.array([(cu - cam.u0) / cam.px, (cv - cam.v0) / cam.py]))
    return pixel_ellipse(cam, (cu, cv), 0.5 * d1 + 0.5, 0.5 * d2 + 0.5, angle, (uv[0], uv[1]))


def pixel_ellipse(
    cam: Any,
    centre: tuple[float, float],
    A: float,
    B: float,
    angle_deg: float,
    centre_uv: tuple[float, float],
) -> EllipseMeasurement:
    """The :class:`EllipseMeasurement` of an ellipse fitted in undistorted pixels: centre
    ``(cu, cv)`` (px), semi-axes ``A``, ``B`` (px), ``angle_deg`` (OpenCV's ``fitEllipse``
    convention); ``centre_uv``: the centre in the (distorted) image, for the record."""
    cu, cv = centre
    n20, n11, n02 = ellipse_moments(A, B, np.deg2rad(angle_deg))
    return EllipseMeasurement(
        float((cu - cam.u0) / cam.px),
        float((cv - cam.v0) / cam.py),
        float(np.pi * A * B / (cam.px * cam.py)),
        n20 / cam.px**2,
        n11 / (cam.px * cam.py),
        n02 / cam.py**2,
        (float(centre_uv[0]), float(centre_uv[1])),
    )


def detect_ellipse(
    image: NDArray[np.uint8],
    optics: Optics,
    *,
    threshold: float | str = "otsu",
    polarity: Polarity = "bright",
    near_uv: ArrayLike | None = None,
    method: EllipseMethod = "moments",
    min_area_px: float = 30.0,
    pad_px: float = 3.0,
    blur_px: float = 0.0,
) -> tuple[EllipseMeasurement | None, str]:
    """Measure the ellipse of one blob of ``image``; return ``(measurement, reason)``.

    Args:
        image: (H, W) uint8 grayscale image.
        optics: Camera intrinsics and distortion.
        threshold: Gray level separating the blob from its surroundings, or ``"otsu"``.
        polarity: ``"bright"`` blob on a darker background, or ``"dark"``.
        near_uv: Predicted centre (pixels): the blob containing it (else the nearest)
            is measured; None = the largest blob.
        method: ``"moments"`` or ``"contour"`` (module docstring).
        min_area_px: Smallest blob area (pixels²).
        pad_px: Margin (pixels) of the moment window; at least 3 x ``blur_px``.
        blur_px: Standard deviation (pixels) of the image blur, removed from the moments.

    Returns:
        The measurement, or None and the reason (no blob, blob touching the border, ...).
    """
    cv2 = require_cv2()
    if method not in ("moments", "contour"):
        raise ConfigurationError(f"ellipse method must be 'moments' or 'contour', got {method!r}")
    mask, _ = binarize(image, threshold, polarity)
    # Every component's outer boundary, nested ones too (RETR_CCOMP puts the outer
    # boundaries at the top level and the holes below): a bright sphere inside a dark
    # region of a bright scene is a blob, which RETR_EXTERNAL would skip.
    contours, hierarchy = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    tree = [] if hierarchy is None else hierarchy[0]
    outer = [c for c, h in zip(contours, tree) if h[3] < 0]
    cnt = _pick(outer, near_uv, min_area_px)
    if cnt is None:
        return None, f"no blob of at least {min_area_px:g} px² for the ellipse"
    x, y, w, h = cv2.boundingRect(cnt)
    H, W = image.shape
    if x <= 0 or y <= 0 or x + w >= W or y + h >= H:
        return None, "the ellipse touches the image border (partly outside the image)"
    if method == "contour":
        meas = _contour_method(cnt, optics)
    else:
        meas = _moments_method(image, cnt, optics, polarity, pad_px, blur_px)
    if meas is None:
        return None, "the ellipse blob is degenerate (too small or no contrast)"
    return meas, ""
