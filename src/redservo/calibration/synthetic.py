"""Images of a calibration pattern seen by a known camera, distortion included (tests, demos).

Each pixel is the average of ``supersample²`` rays through its area: a ray's pixel point is
undistorted by the camera (:meth:`redservo.camera.Camera.pixel_to_normalized`, once per
camera), intersected with the pattern's plane ``z = 0`` (object frame, pose ``cMo``), and
coloured by the pattern there. So the image is exactly what the distorted camera sees, up to
the anti-aliasing; pixel centres are at ``(j + 0.5, i + 0.5)`` (:mod:`redservo.camera`).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.camera import Camera

__all__ = ["render_pattern"]

_PAPER = 235.0
_INK = 20.0
_BACKGROUND = 110.0


@lru_cache(maxsize=4)
def _rays(camera: Camera, supersample: int) -> FloatArray:
    """Undistorted normalized points (h, w, s², 2) of the sub-pixel samples."""
    h, w, s = camera.height, camera.width, supersample
    off = (np.arange(s) + 0.5) / s
    du, dv = np.meshgrid(off, off)
    u = np.arange(w)[None, :, None] + du.ravel()[None, None, :]
    v = np.arange(h)[:, None, None] + dv.ravel()[None, None, :]
    uv = np.stack(np.broadcast_arrays(u, v), axis=-1).reshape(-1, 2)
    xy = camera.pixel_to_normalized(uv)
    return np.asarray(xy.reshape(h, w, s * s, 2), dtype=float)


def render_pattern(
    camera: Camera,
    cMo: FloatArray,
    *,
    pattern: str = "chessboard",
    size: tuple[int, int] = (9, 6),
    spacing: float = 0.025,
    supersample: int = 3,
) -> NDArray[np.uint8]:
    """The 8-bit image of a pattern at pose ``cMo`` (4x4, m).

    Args:
        camera: Intrinsics and distortion.
        cMo: Pose of the pattern's frame (first point at its origin, x along the columns).
        pattern: ``"chessboard"`` (``size`` inner corners, squares of side ``spacing``) or
            ``"circles"`` (``size`` dark circles of diameter ``spacing / 2``).
        size: ``(cols, rows)``.
        spacing: Square side or centre distance (m).
        supersample: Rays per pixel side (anti-aliasing).
    """
    xy = _rays(camera, supersample)
    R, t = cMo[:3, :3], cMo[:3, 3]
    n = R[:, 2]
    denom = xy[..., 0] * n[0] + xy[..., 1] * n[1] + n[2]  # n · (x, y, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = float(n @ t) / denom
    x, y = xy[..., 0], xy[..., 1]
    # X = (λ (x, y, 1) - t) · R[:, 0] / spacing, and Y with R[:, 1]
    X = (lam * (x * R[0, 0] + y * R[1, 0] + R[2, 0]) - t @ R[:, 0]) / spacing
    Y = (lam * (x * R[0, 1] + y * R[1, 1] + R[2, 1]) - t @ R[:, 1]) / spacing
    cols, rows = size
    ok = np.isfinite(lam) & (lam > 0)
    board = ok & (X > -1.6) & (X < cols + 0.6) & (Y > -1.6) & (Y < rows + 0.6)
    value = np.full(X.shape, _BACKGROUND)
    value[board] = _PAPER
    if pattern == "chessboard":
        inner = ok & (X > -1) & (X < cols) & (Y > -1) & (Y < rows)
        dark = inner & ((np.floor(X) + np.floor(Y)) % 2 == 0)
    else:
        cx, cy = np.round(X), np.round(Y)
        near = (cx >= 0) & (cx < cols) & (cy >= 0) & (cy < rows)
        dark = ok & near & ((X - cx) ** 2 + (Y - cy) ** 2 < 0.25**2)
    value[dark] = _INK
    img = value.mean(axis=-1)
    return np.asarray(np.clip(np.rint(img), 0, 255), dtype=np.uint8)
