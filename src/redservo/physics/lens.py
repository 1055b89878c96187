"""A distorted lens for MuJoCo's pinhole camera: render wider, then warp by our lens model.

MuJoCo renders a pinhole image. For a :class:`~redservo.camera.Camera` with lens distortion
(OpenCV's ``k1, k2, p1, p2, k3``), :class:`LensWarp` renders a pinhole image with the same
focal lengths, large enough to hold every ray the distorted image sees, and resamples it
(bilinear, ``cv2.remap``): the output pixel whose centre is ``(u, v)`` (centres at
``j + 0.5``, :mod:`redservo.vision.optics`) takes the pinhole image at
``px x + u0_r, py y + v0_r`` where ``(x, y) = camera.undistort(((u − u0)/px, (v − v0)/py))``
(Newton's method, exact to rounding). A point therefore lands where
``camera.normalized_to_pixel`` puts it, and the image sensor's own undistortion (the same
model) brings the detections back to pinhole coordinates.

Units: pixels.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.vision.optics import require_cv2

__all__ = ["LensWarp"]

_MARGIN_PX = 4.0
"""Pinhole pixels kept around the rays the distorted image sees (bilinear support)."""
_MAX_PX = 8192
"""Largest pinhole render (px per side): beyond, the lens model is taken as not invertible."""


class LensWarp:
    """The pinhole camera MuJoCo renders and its warp to a distorted ``camera`` (module docstring).

    Args:
        camera: The real (distorted) camera.
    """

    def __init__(self, camera: Camera) -> None:
        self.camera = camera
        w, h = camera.width, camera.height
        u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        xd = np.stack([(u - camera.u0) / camera.px, (v - camera.v0) / camera.py], axis=-1)
        xy = camera.undistort(xd)  # (h, w, 2) pinhole coordinates of every output pixel
        lo, hi = xy.reshape(-1, 2).min(axis=0), xy.reshape(-1, 2).max(axis=0)
        f = np.array([camera.px, camera.py])
        c0 = _MARGIN_PX - lo * f  # the pinhole image's principal point
        size = np.ceil((hi - lo) * f + 2 * _MARGIN_PX)
        if not (np.all(np.isfinite(size)) and size.max() <= _MAX_PX):
            raise ConfigurationError(
                f"the lens distortion {camera.distortion} is not invertible over the "
                f"{w}x{h} image (or needs a pinhole render wider than {_MAX_PX} px)",
                argument="camera",
            )
        self.pinhole = Camera(
            camera.px, camera.py, float(c0[0]), float(c0[1]), int(size[0]), int(size[1])
        )
        """The pinhole camera rendered (same focal lengths, wider image, no distortion)."""
        uv = xy * f + c0 - 0.5  # array coordinates (OpenCV: centres on the integers)
        self._map_x = np.ascontiguousarray(uv[..., 0], dtype=np.float32)
        self._map_y = np.ascontiguousarray(uv[..., 1], dtype=np.float32)

    def apply(self, image: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """The distorted image (H, W, ...) of the pinhole render ``image`` (H_r, W_r, ...)."""
        cv2 = require_cv2()
        out: NDArray[np.uint8] = cv2.remap(
            image, self._map_x, self._map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
        )
        return out
