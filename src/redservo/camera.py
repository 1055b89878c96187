"""A pinhole camera: intrinsics, pixel <-> normalized coordinates, projection.

Features work in *normalized* image coordinates ``x = X/Z``, ``y = Y/Z``
(docs/formulas.md §1); pixels only matter for display, for visibility checks and for
the detectors. The pixel of a normalized point is ``u = u0 + px x_d``, ``v = v0 + py y_d``
where ``(x_d, y_d)`` is the point after OpenCV's radial-tangential ("plumb bob") lens
distortion (:meth:`Camera.distort`, coefficients ``k1, k2, p1, p2, k3``; all zero = a
pinhole)::

    r² = x² + y²,   radial = 1 + k1 r² + k2 r⁴ + k3 r⁶
    x_d = x radial + 2 p1 x y + p2 (r² + 2 x²)
    y_d = y radial + p1 (r² + 2 y²) + 2 p2 x y

Pixel convention: pixel edges on the integers, so the pixel in row ``i`` and column ``j``
has its centre at ``(j + 0.5, i + 0.5)``; OpenCV (and ROS) put pixel centres on the
integers, so an OpenCV camera matrix's ``cx, cy`` are ``u0 - 0.5, v0 - 0.5`` here
(:mod:`redservo.calibration.files` converts when it reads or writes a file).

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

__all__ = ["DISTORTION_NAMES", "MIN_DEPTH", "Camera", "project_points"]

DISTORTION_NAMES = ("k1", "k2", "p1", "p2", "k3")
"""OpenCV's order of the five distortion coefficients (``distCoeffs``)."""
_UNDISTORT_ITERATIONS = 30
_UNDISTORT_TOL = 1e-15

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
    """Pinhole intrinsics with OpenCV's radial-tangential distortion (module docstring).

    Attributes:
        px: Horizontal focal length, pixels per normalized unit (> 0).
        py: Vertical focal length, pixels per normalized unit (> 0).
        u0: Principal point abscissa (pixels).
        v0: Principal point ordinate (pixels).
        width: Image width (pixels, > 0).
        height: Image height (pixels, > 0).
        k1, k2, k3: Radial distortion coefficients of r², r⁴, r⁶ (dimensionless; 0 = none).
        p1, p2: Tangential distortion coefficients (dimensionless; 0 = none).
    """

    px: float = 600.0
    py: float = 600.0
    u0: float = 320.0
    v0: float = 240.0
    width: int = 640
    height: int = 480
    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    k3: float = 0.0

    def __post_init__(self) -> None:
        for name in ("px", "py", "width", "height"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ConfigurationError(
                    f"Camera.{name} must be positive and finite, got {value!r}"
                )
        for name in ("u0", "v0", *DISTORTION_NAMES):
            value = getattr(self, name)
            if not np.isfinite(value):
                raise ConfigurationError(f"Camera.{name} must be finite, got {value!r}")

    @property
    def distortion(self) -> tuple[float, float, float, float, float]:
        """``(k1, k2, p1, p2, k3)``, OpenCV's ``distCoeffs`` order."""
        return (self.k1, self.k2, self.p1, self.p2, self.k3)

    @property
    def distorted(self) -> bool:
        """True when any distortion coefficient is non-zero."""
        return any(c != 0.0 for c in self.distortion)

    def distort(self, xy: ArrayLike) -> FloatArray:
        """Distorted normalized coordinates (..., 2) of undistorted (pinhole) ``xy`` (..., 2)
        (the model of the module docstring; ``cv2.projectPoints`` applies the same)."""
        p = np.asarray(xy, dtype=float)
        if not self.distorted:
            return p.copy()
        return _distort(p, self.distortion)[0]

    def undistort(self, xy_d: ArrayLike) -> FloatArray:
        """Undistorted normalized coordinates (..., 2) of distorted ``xy_d`` (..., 2).

        Newton's method on :meth:`distort` from ``x = x_d`` (at most 30 steps, stopped at
        1e-15): exact to rounding wherever the model is invertible (inside the image of
        any real lens). ``cv2.undistortPoints`` solves the same equation by a fixed-point
        iteration (5 steps by default, so less exactly).
        """
        pd = np.asarray(xy_d, dtype=float)
        if not self.distorted:
            return pd.copy()
        p = pd.copy()
        for _ in range(_UNDISTORT_ITERATIONS):
            d, J = _distort(p, self.distortion)
            r = d - pd
            det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
            dx = (J[..., 1, 1] * r[..., 0] - J[..., 0, 1] * r[..., 1]) / det
            dy = (J[..., 0, 0] * r[..., 1] - J[..., 1, 0] * r[..., 0]) / det
            p = p - np.stack([dx, dy], axis=-1)
            if not np.nanmax(np.abs(r), initial=0.0) > _UNDISTORT_TOL:
                break
        return np.asarray(p, dtype=float)

    def pixel_to_normalized(self, uv: ArrayLike) -> FloatArray:
        """Return undistorted normalized coordinates (2,) or (N, 2) of pixels ``uv`` (2,) or
        (N, 2)."""
        p = _as_points(uv, "uv", 2)
        d = np.asarray((p - [self.u0, self.v0]) / [self.px, self.py], dtype=float)
        return self.undistort(d)

    def normalized_to_pixel(self, xy: ArrayLike) -> FloatArray:
        """Return pixels (2,) or (N, 2) of undistorted normalized coordinates ``xy`` (2,) or
        (N, 2) (distorted by the lens)."""
        p = self.distort(_as_points(xy, "xy", 2))
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


def _distort(
    p: FloatArray, c: tuple[float, float, float, float, float]
) -> tuple[FloatArray, FloatArray]:
    """Distorted points (..., 2) of ``p`` (..., 2) and the Jacobian (..., 2, 2) ``∂x_d/∂x``."""
    k1, k2, p1, p2, k3 = c
    x, y = p[..., 0], p[..., 1]
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    drad = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d radial / d r²
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    J = np.empty((*p.shape[:-1], 2, 2))
    J[..., 0, 0] = radial + 2.0 * x * x * drad + 2.0 * p1 * y + 6.0 * p2 * x
    J[..., 0, 1] = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y
    J[..., 1, 0] = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y
    J[..., 1, 1] = radial + 2.0 * y * y * drad + 6.0 * p1 * y + 2.0 * p2 * x
    return np.stack([xd, yd], axis=-1), J
