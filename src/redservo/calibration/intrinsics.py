"""Intrinsic calibration from images of a chessboard or a circle grid (``cv2.calibrateCamera``).

Pattern conventions (OpenCV's): a chessboard ``COLSxROWS`` counts its *inner* corners
(a 9x6 board has 10x7 squares), ``square`` is a square's side (m); a symmetric circle grid
``COLSxROWS`` counts circles, ``spacing`` is the distance between neighbouring centres (m).
The pattern's points are ``(i * square, j * square, 0)``, ``i`` along the columns, in
OpenCV's detection order. The result is a :class:`~redservo.camera.Camera` in redservo's
pixel convention (``u0 = cx + 0.5``; :mod:`redservo.calibration.files`), with the distortion model
fitted (:mod:`~redservo.calibration.distortion`, chosen or ``auto``) and the doubts about
the views (:mod:`~redservo.calibration.views`: repeated views are not used, fewer than three
distinct ones are refused; poor coverage or tilt spread is warned about).
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
from redservo.calibration.distortion import MODELS, choose_model, model_flags
from redservo.calibration.views import (
    MIN_COVERAGE,
    MIN_TILT_SPREAD_DEG,
    MIN_VIEWS,
    coverage,
    duplicates,
    tilt_spread_deg,
)
from redservo.camera import Camera
from redservo.errors import ConfigurationError

__all__ = [
    "MIN_IMAGE_SIDE",
    "CalibrationResult",
    "Pattern",
    "calibrate_camera",
    "grid_points",
    "parse_size",
]

Pattern = Literal["chessboard", "circles"]
MIN_IMAGE_SIDE = 32
"""Smallest width and height (pixels) of a calibration image (the largest is
:data:`redservo.vision.imagefile.MAX_IMAGE_PIXELS`, as for every image redservo reads)."""


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
    """For every image: ``(name, points found (0 = pattern not found), RMS error (px) or None
    when not used)``."""
    poses: list[FloatArray] = field(default_factory=list)
    """``cMo`` (4x4) of the pattern in each used image (:attr:`used_names`)."""
    model: str = "full5"
    """The distortion model fitted (:mod:`redservo.calibration.distortion`)."""
    model_reason: str = ""
    """Why: ``"chosen"`` or what ``auto`` saw."""
    duplicate_of: dict[int, int] = field(default_factory=dict)
    """Images not used because they repeat an earlier one: ``{index: earlier index}`` (into
    :attr:`per_image`)."""
    coverage: float = 0.0
    """Fraction of the image covered by the pattern over the used views (0..1)."""
    tilt_spread_deg: float = 0.0
    """Largest angle between two used views' pattern normals (degrees)."""
    warnings: list[str] = field(default_factory=list)
    """What makes the result doubtful (duplicates, poor coverage or tilt spread, more
    distortion terms than the views support), one sentence each."""

    @property
    def used_names(self) -> list[str]:
        """The images used in the fit, in order (pattern found, not a duplicate)."""
        return [n for i, (n, k, _) in enumerate(self.per_image) if k and i not in self.duplicate_of]

    @property
    def used(self) -> int:
        """How many images were used in the fit."""
        return len(self.used_names)


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
    distortion: str = "auto",
) -> CalibrationResult:
    """Calibrate a camera from images of a planar pattern (module docstring).

    Args:
        images: Image files (any format OpenCV reads, at most
            :data:`~redservo.vision.imagefile.MAX_IMAGE_PIXELS` pixels, checked from the
            header before decoding) or 8-bit arrays (gray or BGR); each side at least
            :data:`MIN_IMAGE_SIDE` pixels.
        pattern: ``"chessboard"`` or ``"circles"`` (a symmetric grid of dark circles).
        size: ``(cols, rows)``: inner corners of a chessboard, circles of a grid.
        spacing: Square side or circle spacing (m).
        names: Names of the images in the report (default: the file names or ``image K``).
        progress: Called with each image's name as it is processed.
        distortion: The distortion model (:mod:`redservo.calibration.distortion`:
            ``none``, ``k1``, ``k1k2``, ``k1k2p``, ``full5``) or ``auto`` (by the number of
            distinct views and their coverage; the result says which and why).

    Raises:
        ConfigurationError: an unreadable, too small or too large image, images of different
            sizes, fewer than :data:`~redservo.calibration.views.MIN_VIEWS` distinct views
            with the pattern (duplicates do not count), a fit that fails, or a bad
            ``pattern``/``size``/``spacing``/``distortion``.
    """
    from redservo.vision.optics import require_cv2

    cv2 = require_cv2()
    if pattern not in ("chessboard", "circles"):
        raise ConfigurationError(f"pattern must be chessboard or circles, got {pattern!r}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise ConfigurationError(f"spacing must be positive (m), got {spacing!r}")
    if distortion != "auto":
        model_flags(cv2, distortion)  # an unknown model fails before any image is read
    found, per_image, shape = _detect_all(cv2, images, pattern, size, names, progress)
    same = duplicates([p for _, p in found], shape)
    dup_of = {found[k][0]: found[j][0] for k, j in same.items()}
    views = [f for i, f in enumerate(found) if i not in same]
    if len(views) < MIN_VIEWS:
        repeats = f" ({len(same)} of them repeat another view)" if same else ""
        raise ConfigurationError(
            f"the {size[0]}x{size[1]} {pattern} was found in {len(found)} of {len(per_image)} "
            f"image(s){repeats}: {len(views)} distinct view(s); calibration needs at least "
            f"{MIN_VIEWS} different views of the pattern (check the pattern size: a chessboard "
            "counts inner corners; move or tilt the pattern between shots)"
        )
    covered = coverage(cv2, [p for _, p in views], shape)
    model, why = choose_model(len(views), covered)
    if distortion != "auto":
        if MODELS.index(distortion) > MODELS.index(model):
            seen = why.removeprefix("auto: ").split(";")[0]
            why = f"chosen; {seen} support {model} at most"
        else:
            why = "chosen"
        model = distortion
    res = _fit(cv2, grid_points(size, spacing), views, shape, model, per_image)
    res.model, res.model_reason, res.duplicate_of = model, why, dup_of
    res.coverage, res.tilt_spread_deg = covered, tilt_spread_deg(res.poses)
    res.warnings = _doubts(res)
    return res


def _doubts(res: CalibrationResult) -> list[str]:
    """The warnings of a calibration (:attr:`CalibrationResult.warnings`)."""
    name = [n for n, _, _ in res.per_image]
    notes = [f"{name[a]} repeats {name[b]} (not used)" for a, b in res.duplicate_of.items()]
    if res.coverage < MIN_COVERAGE:
        notes.append(
            f"the pattern covers {res.coverage:.0%} of the image over all views (less than "
            f"{MIN_COVERAGE:.0%}): the distortion near the edges is extrapolated; show the "
            "pattern in the corners too"
        )
    if res.tilt_spread_deg < MIN_TILT_SPREAD_DEG:
        notes.append(
            f"the views are tilted by at most {res.tilt_spread_deg:.1f} deg from one another "
            f"(less than {MIN_TILT_SPREAD_DEG:g}): the focal length is poorly determined; "
            "tilt the pattern by 20-40 deg about different axes"
        )
    if "support" in res.model_reason:
        notes.append(
            f"distortion {res.model} fits more terms than the views support ({res.model_reason})"
        )
    return notes


def _fit(
    cv2: Any,
    obj3: FloatArray,
    views: list[tuple[int, FloatArray]],
    shape: tuple[int, int],
    model: str,
    per_image: list[tuple[str, int, float | None]],
) -> CalibrationResult:
    """``cv2.calibrateCamera`` on ``views`` with ``model``; the per-image errors filled in."""
    obj = obj3.astype(np.float32)
    img_pts = [p.astype(np.float32).reshape(-1, 1, 2) for _, p in views]
    try:
        rms, K, D, rvecs, tvecs = cv2.calibrateCamera(
            [obj.reshape(-1, 1, 3)] * len(views),
            img_pts,
            (shape[1], shape[0]),
            None,
            np.zeros(5),
            flags=model_flags(cv2, model),
        )
    except cv2.error as exc:
        raise ConfigurationError(
            f"cv2.calibrateCamera failed: {' '.join(str(exc).split())}"
        ) from None
    D = np.concatenate([np.asarray(D, dtype=float).ravel(), np.zeros(5)])[:5]
    if not (np.isfinite(K).all() and np.isfinite(D).all() and K[0, 0] > 0 and K[1, 1] > 0):
        raise ConfigurationError("cv2.calibrateCamera found no valid camera (degenerate views)")
    u0, v0 = float(K[0, 2]) + 0.5, float(K[1, 2]) + 0.5
    k1, k2, p1, p2, k3 = map(float, D)
    camera = Camera(
        float(K[0, 0]),
        float(K[1, 1]),
        u0,
        v0,
        shape[1],
        shape[0],
        k1=k1,
        k2=k2,
        p1=p1,
        p2=p2,
        k3=k3,
    )
    poses = []
    for (k, pts), rv, tv in zip(views, rvecs, tvecs, strict=True):
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
    """The image in grayscale; a file is read by :func:`redservo.vision.imagefile.read_gray`
    (a regular file, its size checked from the header before decoding)."""
    from redservo.vision.imagefile import check_frame_size, read_gray

    if isinstance(item, np.ndarray):
        img = item
        if img.ndim not in (2, 3):
            raise ConfigurationError(f"{name}: expected a 2-D or 3-D image, got shape {img.shape}")
        check_frame_size(img.shape[1], img.shape[0], name)
    else:
        if not Path(item).is_file():
            raise ConfigurationError(f"{name}: no such image file", argument="images")
        img = read_gray(Path(item))
    if img.dtype != np.uint8:
        raise ConfigurationError(f"{name}: expected an 8-bit image, got {img.dtype}")
    if min(img.shape[:2]) < MIN_IMAGE_SIDE:
        raise ConfigurationError(
            f"{name}: the image is {img.shape[1]} x {img.shape[0]} pixels; a calibration "
            f"image needs at least {MIN_IMAGE_SIDE} pixels on each side",
            argument="images",
        )
    if img.ndim == 3:
        code = cv2.COLOR_BGRA2GRAY if img.shape[2] == 4 else cv2.COLOR_BGR2GRAY
        img = cv2.cvtColor(img, code)
    return np.ascontiguousarray(img)
