"""Pixels of a real camera: intrinsics, radial distortion and the pixel-centre convention.

:class:`~redservo.camera.Camera` maps normalized coordinates to pixels with its own
distortion (OpenCV's full ``k1, k2, p1, p2, k3`` model; a camera loaded from a calibration
file has it), which :class:`Optics` then uses. Without it, :class:`Optics` can add a radial
(Brown) distortion of the *normalized* coordinates, the convention of OpenCV's ``k1, k2``::

    x_d = x (1 + k1 r² + k2 r⁴),   y_d = y (1 + k1 r² + k2 r⁴),   r² = x² + y²
    u = u0 + px x_d,               v = v0 + py y_d

where ``(x, y)`` are the undistorted (pinhole) normalized coordinates that every
feature uses. :meth:`Optics.to_normalized` inverts it by a fixed-point
iteration, exact to 1e-12 for moderate distortion (``|k1| <= 0.5``,
``|k2| <= 0.5`` inside the image).

Pixel convention (the one of :mod:`redservo.camera`): the image is the
rectangle ``0 <= u <= width``, ``0 <= v <= height`` with pixel edges on the
integers, so the pixel in row ``i`` and column ``j`` has its centre at
``(u, v) = (j + 0.5, i + 0.5)``. OpenCV puts pixel centres on the integers;
every detector here adds 0.5 where it calls OpenCV.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import ConfigurationError

__all__ = ["Optics", "require_cv2"]

_UNDISTORT_ITERATIONS = 40


def require_cv2() -> ModuleType:
    """Import OpenCV, or raise :class:`ConfigurationError` naming the extra to install."""
    try:
        import cv2
    except ImportError as exc:  # pragma: no cover - the extra is installed in CI
        raise ConfigurationError(
            "the image pipeline needs OpenCV: pip install 'redservo[vision]' "
            f"(opencv-python-headless); import failed: {exc}"
        ) from None
    return cv2


@dataclass(frozen=True, eq=False)
class Optics:
    """A pinhole camera with radial distortion.

    Attributes:
        camera: Intrinsics and image size.
        k1: Radial distortion coefficient of ``r²`` (dimensionless; 0 = none).
        k2: Radial distortion coefficient of ``r⁴`` (dimensionless; 0 = none).
    """

    camera: Camera = field(default_factory=Camera)
    k1: float = 0.0
    k2: float = 0.0
    _maps: dict[str, Any] = field(default_factory=dict, init=False, repr=False)
    _distorted: bool = field(default=False, init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.camera, Camera):
            raise ConfigurationError(
                f"Optics.camera must be a redservo.camera.Camera, got {type(self.camera).__name__}"
            )
        for name in ("k1", "k2"):
            value = float(getattr(self, name))
            if not (np.isfinite(value) and abs(value) <= 1.0):
                raise ConfigurationError(
                    f"distortion {name} must be finite with |{name}| <= 1, got {value!r}"
                )
            object.__setattr__(self, name, value)
        if self.camera.distorted and (self.k1 or self.k2):
            raise ConfigurationError(
                "the distortion is given twice: the camera has k1, k2, p1, p2, k3 and Optics "
                "k1, k2; give it in one place (the camera's is OpenCV's full model)"
            )
        distorted = self.k1 != 0.0 or self.k2 != 0.0 or self.camera.distorted
        object.__setattr__(self, "_distorted", distorted)  # frozen: asked at every frame

    @property
    def distorted(self) -> bool:
        """True when ``k1`` or ``k2`` (or the camera's distortion) is non-zero."""
        return self._distorted

    @property
    def shape(self) -> tuple[int, int]:
        """Image shape ``(height, width)`` in pixels."""
        return int(self.camera.height), int(self.camera.width)

    # -- distortion ----------------------------------------------------------------------------

    def distort(self, xy: ArrayLike) -> FloatArray:
        """Distorted normalized coordinates (..., 2) of undistorted ``xy`` (..., 2)."""
        p = np.asarray(xy, dtype=float)
        if not self.distorted:
            return p.copy()
        if self.camera.distorted:
            return self.camera.distort(p)
        r2 = p[..., 0] ** 2 + p[..., 1] ** 2
        return np.asarray(p * (1.0 + r2 * (self.k1 + self.k2 * r2))[..., None], dtype=float)

    def undistort(self, xy_d: ArrayLike) -> FloatArray:
        """Undistorted normalized coordinates (..., 2) of distorted ``xy_d`` (..., 2)."""
        pd = np.asarray(xy_d, dtype=float)
        if not self.distorted:
            return pd.copy()
        if self.camera.distorted:
            return self.camera.undistort(pd)
        p = pd.copy()
        for _ in range(_UNDISTORT_ITERATIONS):
            r2 = p[..., 0] ** 2 + p[..., 1] ** 2
            p = pd / (1.0 + r2 * (self.k1 + self.k2 * r2))[..., None]
        return np.asarray(p, dtype=float)

    # -- pixels --------------------------------------------------------------------------------

    def to_pixel(self, xy: ArrayLike) -> FloatArray:
        """Pixel coordinates ``(u, v)`` (..., 2) of undistorted normalized ``xy`` (..., 2)."""
        c = self.camera
        d = self.distort(xy)
        return np.asarray(d * [c.px, c.py] + [c.u0, c.v0], dtype=float)

    def to_normalized(self, uv: ArrayLike) -> FloatArray:
        """Undistorted normalized coordinates (..., 2) of pixel coordinates ``uv`` (..., 2)."""
        c = self.camera
        d = (np.asarray(uv, dtype=float) - [c.u0, c.v0]) / [c.px, c.py]
        return self.undistort(d)

    def grid(self, rows: slice, cols: slice) -> tuple[FloatArray, FloatArray]:
        """Undistorted normalized ``(x, y)`` of the pixel centres in ``rows`` x ``cols``.

        Both arrays have shape ``(len(rows), len(cols))``. Without distortion they
        are computed on the fly; with distortion the full-image map is computed once
        and sliced.
        """
        c = self.camera
        if not self.distorted:
            u = (np.arange(cols.start, cols.stop) + 0.5 - c.u0) / c.px
            v = (np.arange(rows.start, rows.stop) + 0.5 - c.v0) / c.py
            x, y = np.meshgrid(u, v)
            return x, y
        full = self._full_map()
        return full[0][rows, cols], full[1][rows, cols]

    def _full_map(self) -> tuple[FloatArray, FloatArray]:
        if "xy" not in self._maps:
            h, w = self.shape
            u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
            xy = self.to_normalized(np.stack([u, v], axis=-1))
            self._maps["xy"] = (np.ascontiguousarray(xy[..., 0]), np.ascontiguousarray(xy[..., 1]))
        out: tuple[FloatArray, FloatArray] = self._maps["xy"]
        return out

    def pixel_area(self, rows: slice, cols: slice) -> FloatArray | float:
        """Area (normalized units²) that each pixel of ``rows`` x ``cols`` covers.

        ``1/(px py)`` without distortion; otherwise the Jacobian determinant of the
        undistortion map (by central differences of the full-image map).
        """
        c = self.camera
        if not self.distorted:
            return 1.0 / (c.px * c.py)
        if "area" not in self._maps:
            x, y = self._full_map()
            xu, xv = np.gradient(x, axis=1), np.gradient(x, axis=0)
            yu, yv = np.gradient(y, axis=1), np.gradient(y, axis=0)
            self._maps["area"] = np.abs(xu * yv - xv * yu)
        area: FloatArray = self._maps["area"][rows, cols]
        return area

    def __repr__(self) -> str:
        return f"Optics({self.camera!r}, k1={self.k1}, k2={self.k2})"
