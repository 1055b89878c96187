"""A pinhole camera: intrinsics, pixel <-> normalized coordinates, projection.

Features work in *normalized* image coordinates ``x = X/Z``, ``y = Y/Z``
(docs/formulas.md §1); pixels only matter for display and for visibility checks.
The pixel of a normalized point is ``u = u0 + px x``, ``v = v0 + py y`` (no
distortion).

Decisions:
    * A point is projectable only if its depth exceeds :data:`MIN_DEPTH`
      (1 µm); closer to the camera plane ``1/Z`` is not meaningful. Every
      feature uses the same threshold.
    * The image is the continuous rectangle ``0 <= u <= width``,
      ``0 <= v <= height`` (pixel edges, not pixel centres); ``margin_px``
      shrinks it on every side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, GeometryError, ShapeError

__all__ = ["MIN_DEPTH", "Camera", "project_points"]

MIN_DEPTH = 1e-6
"""Smallest depth Z (m) at which a point is considered in front of the camera."""


def _as_points(value: ArrayLike, name: str, dim: int) -> FloatArray:
    """Return ``value`` as a finite float array of shape (dim,) or (N, dim)."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim not in (1, 2) or arr.shape[-1] != dim:
        raise ShapeError(f"{name} must have shape ({dim},) or (N, {dim}), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ShapeError(f"{name} must be finite (no NaN or inf)")
    return arr


def project_points(points_c: ArrayLike) -> FloatArray:
    """Project points given in the camera frame to normalized image coordinates.

    Args:
        points_c: (N, 3) or (3,) points ``(X, Y, Z)`` in the camera frame (m).

    Returns:
        (N, 2) or (2,) normalized coordinates ``(X/Z, Y/Z)``.

    Raises:
        ShapeError: wrong shape or non-finite values.
        GeometryError: a point has ``Z <= MIN_DEPTH`` (at or behind the camera plane).
    """
    P = _as_points(points_c, "points_c", 3)
    Z = P[..., 2]
    bad = np.flatnonzero(np.atleast_1d(Z) <= MIN_DEPTH)
    if bad.size:
        i = int(bad[0])
        z = float(np.atleast_1d(Z)[i])
        raise GeometryError(
            f"point {i} is at or behind the camera plane (Z = {z:.6g} m); "
            f"projection needs Z > {MIN_DEPTH:g} m"
        )
    return np.asarray(P[..., :2] / Z[..., None], dtype=float)


@dataclass(frozen=True)
class Camera:
    """Pinhole intrinsics (no distortion).

    Attributes:
        px: Horizontal focal length, pixels per normalized unit (> 0).
        py: Vertical focal length, pixels per normalized unit (> 0).
        u0: Principal point abscissa (pixels).
        v0: Principal point ordinate (pixels).
        width: Image width (pixels, > 0).
        height: Image height (pixels, > 0).
    """

    px: float = 600.0
    py: float = 600.0
    u0: float = 320.0
    v0: float = 240.0
    width: int = 640
    height: int = 480

    def __post_init__(self) -> None:
        for name in ("px", "py", "width", "height"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ConfigurationError(
                    f"Camera.{name} must be positive and finite, got {value!r}"
                )
        for name in ("u0", "v0"):
            value = getattr(self, name)
            if not np.isfinite(value):
                raise ConfigurationError(f"Camera.{name} must be finite, got {value!r}")

    def pixel_to_normalized(self, uv: ArrayLike) -> FloatArray:
        """Return normalized coordinates (2,) or (N, 2) of pixels ``uv`` (2,) or (N, 2)."""
        p = _as_points(uv, "uv", 2)
        return np.asarray((p - [self.u0, self.v0]) / [self.px, self.py], dtype=float)

    def normalized_to_pixel(self, xy: ArrayLike) -> FloatArray:
        """Return pixels (2,) or (N, 2) of normalized coordinates ``xy`` (2,) or (N, 2)."""
        p = _as_points(xy, "xy", 2)
        return np.asarray(p * [self.px, self.py] + [self.u0, self.v0], dtype=float)

    def project(self, points_c: ArrayLike) -> FloatArray:
        """Normalized coordinates (N, 2) of camera-frame points (N, 3); see :func:`project_points`."""
        return project_points(points_c)

    def in_image(self, xy: ArrayLike, margin_px: float = 0.0) -> NDArray[np.bool_]:
        """Return whether normalized points lie in the image, ``margin_px`` pixels inside its border.

        Args:
            xy: (2,) or (N, 2) normalized coordinates.
            margin_px: Margin (pixels) kept free on every side; may be negative.

        Returns:
            Boolean array of shape () for one point or (N,).
        """
        uv = self.normalized_to_pixel(xy)
        m = float(margin_px)
        u, v = uv[..., 0], uv[..., 1]
        inside = (u >= m) & (u <= self.width - m) & (v >= m) & (v <= self.height - m)
        return np.asarray(inside, dtype=bool)
