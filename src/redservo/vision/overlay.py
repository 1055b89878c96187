"""The video overlay of the shipped feature kinds (their ``draw`` adapter,
:mod:`redservo.features.kinds`; drawn by :mod:`redservo.vision.video`).

Each ``draw_*(img, optics, feature, s, color)`` draws the value ``s`` (normalized image
coordinates) of one term on the RGB image ``img`` in ``color`` (OpenCV drawing,
anti-aliased): a point as a circle (current) or a cross (desired, :data:`DESIRED`), a
sphere as its ellipse, a cylinder's limbs and a line as lines, moments as the centroid
``(xn/an, yn/an)`` with a segment along the orientation α.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray
from redservo.features.sphere import sphere_moments_from_area
from redservo.plots.style import role_rgb
from redservo.vision.optics import Optics, require_cv2

__all__ = [
    "DESIRED",
    "draw_cylinder",
    "draw_line",
    "draw_line_term",
    "draw_moments",
    "draw_point",
    "draw_point_term",
    "draw_sphere",
    "px",
]

DESIRED = role_rgb("desired")
"""The colour of the desired features (a point is drawn as a cross in it)."""


def px(optics: Optics, xy: ArrayLike) -> NDArray[np.int32]:
    """Integer pixel positions (k, 2) of normalized points ``xy``, clipped to ±1e4."""
    uv = optics.to_pixel(np.asarray(xy, dtype=float).reshape(-1, 2))
    uv = np.where(np.isfinite(uv), uv, -1e4)
    return np.clip(np.round(uv), -1e4, 1e4).astype(np.int32)


def draw_line(img: NDArray[np.uint8], optics: Optics, rho: float, theta: float, color: Any) -> None:
    """The image line ``(ρ, θ)`` (normalized units, rad)."""
    cv2 = require_cv2()
    n = np.array([np.cos(theta), np.sin(theta)])
    d = np.array([-n[1], n[0]])
    t = np.linspace(-3.0, 3.0, 241)
    pts = px(optics, rho * n + t[:, None] * d)
    cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, color, 2, cv2.LINE_AA)


def draw_point(img: NDArray[np.uint8], u: int, v: int, color: Any) -> None:
    """A current point as a circle, a desired one as a cross (the viewer's shapes)."""
    cv2 = require_cv2()
    if color == DESIRED:
        cv2.drawMarker(img, (u, v), color, cv2.MARKER_CROSS, 16, 2, cv2.LINE_AA)
    else:
        cv2.circle(img, (u, v), 7, color, 2, cv2.LINE_AA)


def draw_point_term(
    img: NDArray[np.uint8], optics: Optics, feature: Any, s: FloatArray, color: Any
) -> None:
    """A point feature ``(x, y)``."""
    ((u, v),) = px(optics, s[:2])
    draw_point(img, int(u), int(v), color)


def draw_sphere(
    img: NDArray[np.uint8], optics: Optics, feature: Any, s: FloatArray, color: Any
) -> None:
    """A sphere's ellipse, from either variant of its features."""
    cv2 = require_cv2()
    if feature.variant == "moments":
        xc, yc, n20, n11, n02 = s
    else:
        xc, yc = s[0], s[1]
        n20, n11, n02 = sphere_moments_from_area(s[0], s[1], s[2])
    evals, evecs = np.linalg.eigh(4.0 * np.array([[n20, n11], [n11, n02]]))
    t = np.linspace(0.0, 2.0 * np.pi, 73)
    axes = evecs * np.sqrt(np.maximum(evals, 0.0))
    pts = px(optics, np.array([xc, yc]) + (axes @ np.stack([np.cos(t), np.sin(t)])).T)
    cv2.polylines(img, [pts.reshape(-1, 1, 2)], True, color, 2, cv2.LINE_AA)


def draw_cylinder(
    img: NDArray[np.uint8], optics: Optics, feature: Any, s: FloatArray, color: Any
) -> None:
    """A cylinder's two limbs."""
    draw_line(img, optics, float(s[0]), float(s[1]), color)
    draw_line(img, optics, float(s[2]), float(s[3]), color)


def draw_line_term(
    img: NDArray[np.uint8], optics: Optics, feature: Any, s: FloatArray, color: Any
) -> None:
    """A line feature ``(ρ, θ)``."""
    draw_line(img, optics, float(s[0]), float(s[1]), color)


def draw_moments(
    img: NDArray[np.uint8], optics: Optics, feature: Any, s: FloatArray, color: Any
) -> None:
    """The moments' centroid and a segment along their orientation α."""
    cv2 = require_cv2()
    xg, yg, alpha = s[0] / s[2], s[1] / s[2], s[3]
    c = px(optics, [xg, yg])[0]
    draw_point(img, int(c[0]), int(c[1]), color)
    tip = c + np.round(40.0 * np.array([np.cos(alpha), np.sin(alpha)])).astype(np.int32)
    cv2.line(img, (int(c[0]), int(c[1])), (int(tip[0]), int(tip[1])), color, 2, cv2.LINE_AA)
