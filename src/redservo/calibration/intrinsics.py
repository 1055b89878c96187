"""Intrinsic calibration from images of a chessboard or a circle grid (``cv2.calibrateCamera``).

Pattern conventions (OpenCV's): a chessboard ``COLSxROWS`` counts its *inner* corners
(a 9x6 board has 10x7 squares), ``square`` is a square's side (m); a symmetric circle grid
``COLSxROWS`` counts circles, ``spacing`` is the distance between neighbouring centres (m).
The pattern's points are ``(i * square, j * square, 0)``, ``i`` along the columns, in
OpenCV's detection order. The result is a :class:`~redservo.camera.Camera` in redservo's
pixel convention (``u0 = cx + 0.5``; :mod:`redservo.camera_io`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import ConfigurationError

__all__ = ["CalibrationResult", "Pattern", "calibrate_camera", "grid_points", "parse_size"]

Pattern = Literal["chessboard", "circles"]


def parse_size(text: str, what: str) -> tuple[int, int]:
    """``"9x6"`` -> ``(9, 6)``.

    Raises:
        ConfigurationError: not two integers >= 2 joined by ``x``.
    """
    parts = text.lower().split("x")
    try:
        cols, rows = (int(p) for p in parts)
    except ValueError:
        cols = rows = 0
    if len(parts) != 2 or cols < 2 or rows < 2:
        raise ConfigurationError(
            f"{what} must be COLSxROWS with two integers >= 2 (e.g. 9x6), got {text!r}",
            argument=what,
        )
    return cols, rows


def grid_points(size: tuple[int, int], spacing: float) -> FloatArray:
    """The pattern's points (cols*rows, 3) in its own frame (m): ``(i s, j s, 0)``, row-major."""
    cols, rows = size
    j, i = np.mgrid[0:rows, 0:cols]
    return np.column_stack([i.ravel(), j.ravel(), np.zeros(i.size)]) * float(spacing)


@dataclass
class CalibrationResult:
    """What :func:`calibrate_camera` found."""

    camera: Camera
    """The intrinsics and distortion (redservo's pixel convention)."""
    rms_px: float
    """RMS reprojection error over every used point (pixels), as ``cv2.calibrateCamera``."""
    per_image: list[tuple[str, int, float | None]]
    """For every image: ``(name, points found (0 = pattern not found), RMS error (px) or None)``."""
    poses: list[FloatArray] = field(default_factory=list)
    """``cMo`` (4x4) of the pattern in each used image."""

    @property
    def used(self) -> int:
        """How many images had the pattern."""
        return sum(1 for _, n, _ in self.per_image if n)


def _detect(
    cv2: Any, gray: NDArray[np.uint8], pattern: Pattern, size: tuple[int, int]
) -> FloatArray | None:
    """The pattern's points (N, 2) in OpenCV pixels, or None."""
    if pattern == "chessboard":
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        ok, corners = cv2.findChessboardCorners(gray, size, flags=flags)
        if not ok:
            return None
        crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
        corners = cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), crit)
    else:
        ok, corners = cv2.findCirclesGrid(gray, size, flags=cv2.CALIB_CB_SYMMETRIC_GRID)
        if not ok:
            return None
    return np.asarray(corners, dtype=float).reshape(-1, 2)


def calibrate_camera(
    images: Sequence[str | os.PathLike[str] | NDArray[np.uint8]],
    *,
    pattern: Pattern = "chessboard",
    size: tuple[int, int] = (9, 6),
    spacing: float = 0.025,
    names: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> CalibrationResult:
    """Calibrate a camera from images of a planar pattern (module docstring).

    Args:
        images: Image files (any format OpenCV reads) or 8-bit arrays (gray or BGR).
        pattern: ``"chessboard"`` or ``"circles"`` (a symmetric grid of dark circles).
        size: ``(cols, rows)``: inner corners of a chessboard, circles of a grid.
        spacing: Square side or circle spacing (m).
        names: Names of the images in the report (default: the file names or ``image K``).
        progress: Called with each image's name as it is processed.

    Raises:
        ConfigurationError: an unreadable image, images of different sizes, fewer than 3
            images with the pattern, or a bad ``pattern``/``size``/``spacing``.
    """
    from redservo.vision.optics import require_cv2

    cv2 = require_cv2()
    if pattern not in ("chessboard", "circles"):
        raise ConfigurationError(f"pattern must be chessboard or circles, got {pattern!r}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise ConfigurationError(f"spacing must be positive (m), got {spacing!r}")
    obj = grid_points(size, spacing).astype(np.float32)
    found, per_image, shape = _detect_all(cv2, images, pattern, size, names, progress)
    if len(found) < 3:
        raise ConfigurationError(
            f"the {size[0]}x{size[1]} {pattern} was found in {len(found)} of {len(per_image)} "
            "image(s); calibration needs at least 3 (check the pattern size: a chessboard "
            "counts inner corners)"
        )
    img_pts = [p.astype(np.float32).reshape(-1, 1, 2) for _, p in found]
    obj_pts = [obj.reshape(-1, 1, 3)] * len(found)
    flags = cv2.CALIB_FIX_SKEW if hasattr(cv2, "CALIB_FIX_SKEW") else 0
    rms, K, D, rvecs, tvecs = cv2.calibrateCamera(
        obj_pts, img_pts, (shape[1], shape[0]), None, None, flags=flags
    )
    D = np.asarray(D, dtype=float).ravel()
    camera = Camera(
        px=float(K[0, 0]),
        py=float(K[1, 1]),
        u0=float(K[0, 2]) + 0.5,
        v0=float(K[1, 2]) + 0.5,
        width=shape[1],
        height=shape[0],
        **dict(zip(("k1", "k2", "p1", "p2", "k3"), map(float, D[:5]), strict=True)),
    )
    poses = []
    for (k, pts), rv, tv in zip(found, rvecs, tvecs, strict=True):
        proj, _ = cv2.projectPoints(obj, rv, tv, K, D)
        err = float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - pts) ** 2, axis=1))))
        per_image[k] = (per_image[k][0], per_image[k][1], err)
        T = np.eye(4)
        T[:3, :3] = cv2.Rodrigues(rv)[0]
        T[:3, 3] = np.ravel(tv)
        poses.append(T)
    return CalibrationResult(camera, float(rms), per_image, poses)


def _detect_all(
    cv2: Any,
    images: Sequence[str | os.PathLike[str] | NDArray[np.uint8]],
    pattern: Pattern,
    size: tuple[int, int],
    names: Sequence[str] | None,
    progress: Callable[[str], None] | None,
) -> tuple[list[tuple[int, FloatArray]], list[tuple[str, int, float | None]], tuple[int, int]]:
    """The pattern's points in each image where it was found ``(index, (N, 2))``, the
    per-image report and the image shape ``(height, width)``."""
    found: list[tuple[int, FloatArray]] = []
    per_image: list[tuple[str, int, float | None]] = []
    shape: tuple[int, int] = (0, 0)
    for k, item in enumerate(images):
        name = (
            names[k]
            if names is not None
            else (str(item) if not isinstance(item, np.ndarray) else f"image {k}")
        )
        if progress is not None:
            progress(name)
        gray = _gray(cv2, item, name)
        if k == 0:
            shape = (gray.shape[0], gray.shape[1])
        elif gray.shape[:2] != shape:
            raise ConfigurationError(
                f"{name}: image size {gray.shape[1]}x{gray.shape[0]} differs from the first "
                f"image's {shape[1]}x{shape[0]}; calibrate one camera mode at a time"
            )
        pts = _detect(cv2, gray, pattern, size)
        per_image.append((name, 0 if pts is None else len(pts), None))
        if pts is not None:
            found.append((k, pts))
    return found, per_image, shape


def _gray(
    cv2: Any, item: str | os.PathLike[str] | NDArray[np.uint8], name: str
) -> NDArray[np.uint8]:
    if isinstance(item, np.ndarray):
        img = item
    else:
        if not Path(item).is_file():
            raise ConfigurationError(f"{name}: no such image file", argument="images")
        img = cv2.imread(str(item), cv2.IMREAD_UNCHANGED)
        if img is None:
            raise ConfigurationError(f"{name}: not an image OpenCV can read", argument="images")
    if img.dtype != np.uint8:
        raise ConfigurationError(f"{name}: expected an 8-bit image, got {img.dtype}")
    if img.ndim == 3:
        code = cv2.COLOR_BGRA2GRAY if img.shape[2] == 4 else cv2.COLOR_BGR2GRAY
        img = cv2.cvtColor(img, code)
    return np.ascontiguousarray(img)
