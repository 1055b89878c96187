"""Fiducial tags (AprilTag 36h11, 36h10, 25h9, 16h5 and the ArUco dictionaries) in an image.

:func:`detect_tags` runs OpenCV's ``cv2.aruco.ArucoDetector`` to find and decode the tags, then
places each corner at the intersection of its two edges fitted to sub-pixel
(:func:`~redservo.vision.tag_refine.refine_quad`; the choice, with numbers, in
docs/decisions.md) and,
given the camera and the tag's side, its pose by ``cv2.solvePnPGeneric`` with
``SOLVEPNP_IPPE_SQUARE`` (both poses of the planar ambiguity), each refined by
``cv2.solvePnPRefineLM``.

Conventions (docs/vision.md, Tags):

* pixels: redservo's (:mod:`redservo.vision.optics`): pixel edges on the integers, the centre
  of the pixel in row ``i``, column ``j`` at ``(j + 0.5, i + 0.5)`` (also AprilTag 3's; OpenCV
  puts centres on the integers and we add 0.5);
* corner order: AprilTag 3's and ViSP's, corner ``k`` the image of the tag-frame point
  ``size/2 · ((-1, -1), (1, -1), (1, 1), (-1, 1))[k]``: counter-clockwise in the image when the
  printed face is seen;
* tag frame (``cMo``): ViSP's ``vpDetectorAprilTag`` frame, origin at the tag centre, tag in
  ``z = 0``, ``z`` out of the printed face (towards a camera that sees the tag), ``x`` from
  corner 0 to corner 1, ``y`` from corner 1 to corner 2; ``z_aligned=True`` gives ViSP's
  ``setZAlignedWithCameraAxis(true)`` frame instead (rotated by π about ``x``: ``z`` into the
  tag, so a tag facing the camera has ``cRo = I``).

The camera's distortion is used when it has one: ``k1, k2, p1, p2, k3`` attributes of the
camera (OpenCV's radial-tangential model; missing ones are 0), or an
:class:`~redservo.vision.optics.Optics` (``k1, k2``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import ConfigurationError, ShapeError
from redservo.vision.optics import Optics, require_cv2
from redservo.vision.tag_families import TAG_FAMILIES, check_tag, tag_points
from redservo.vision.tag_refine import refine_quad

__all__ = ["TagDetection", "detect_tags", "iter_tags", "tag_corners"]

# OpenCV's corners (top-left, top-right, bottom-right, bottom-left of the marker image) in
# AprilTag 3's order: AprilTag's corner k is OpenCV's corner _CV_OF[k] (measured with the
# AprilTag 3 bindings on the same images, tests/test_vision_tags.py).
_CV_OF = np.array([1, 0, 3, 2])
# SOLVEPNP_IPPE_SQUARE's object frame (OpenCV corners at size/2 (-1, 1), (1, 1), (1, -1),
# (-1, -1)) to the ViSP frame: a rotation by π about z.
_RZ_PI = np.diag([-1.0, -1.0, 1.0, 1.0])
_RX_PI = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass(frozen=True)
class TagDetection:
    """One detected tag.

    Attributes:
        id: The tag's id in its family (0-based).
        corners: (4, 2) its outer corners in pixels (module docstring: pixel convention, order).
        cMo: (4, 4) its pose in the camera frame (m), or None without camera and size.
        reprojection_px: RMS distance (pixels) between the corners and the pose's projection of
            them, NaN without a pose.
        cMo_alt: (4, 4) the other pose of the planar ambiguity (IPPE's second solution, as
            ViSP's ``cMo2``), whose reprojection error is ``reprojection_alt_px`` (>= the
            first); a tracker picks the one consistent with the previous frame.
        reprojection_alt_px: Its RMS reprojection error (pixels).
    """

    id: int
    corners: FloatArray
    cMo: FloatArray | None = None
    reprojection_px: float = float("nan")
    cMo_alt: FloatArray | None = None
    reprojection_alt_px: float = float("nan")


def tag_corners(size: float) -> FloatArray:
    """(4, 3) the tag-frame corners (m) of a tag of side ``size``, in the detection order."""
    return tag_points(size)


@lru_cache(maxsize=16)
def _detector(family: str) -> Any:
    cv2 = require_cv2()
    const = TAG_FAMILIES[family][0]
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, const))
    p = cv2.aruco.DetectorParameters()
    p.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE  # refine_quad does better
    # Two adaptive-threshold windows (5 and 21 px) instead of OpenCV's three (3, 13, 23): the
    # detector's main cost, 0.6x the time with the same detections on the benchmark's tags
    # (docs/vision.md, "Tags").
    p.adaptiveThreshWinSizeMin, p.adaptiveThreshWinSizeMax = 5, 21
    p.adaptiveThreshWinSizeStep = 16
    return cv2.aruco.ArucoDetector(d, p)


def _intrinsics(camera: Camera | Optics) -> tuple[FloatArray, FloatArray]:
    """OpenCV's camera matrix (pixel centres on the integers) and distortion vector."""
    if isinstance(camera, Optics | Camera):
        cam = camera.camera if isinstance(camera, Optics) else camera
        # the camera's own distortion (OpenCV's model) if any, else an Optics' k1, k2
        src = cam if getattr(cam, "distorted", False) else camera
        dist = [float(getattr(src, k, 0.0) or 0.0) for k in ("k1", "k2", "p1", "p2", "k3")]
    else:
        raise ConfigurationError(
            f"camera must be a redservo.camera.Camera or an Optics, got {type(camera).__name__}"
        )
    K = np.array([[cam.px, 0.0, cam.u0 - 0.5], [0.0, cam.py, cam.v0 - 0.5], [0.0, 0.0, 1.0]])
    return K, np.asarray(dist, dtype=float)


def _pose(
    cv_corners: FloatArray, size: float, K: FloatArray, dist: FloatArray
) -> list[tuple[FloatArray, float]]:
    """The poses ``cMo`` (ViSP frame) of IPPE's solutions with their RMS reprojection error
    (px), best first, from OpenCV-order corners."""
    cv2 = require_cv2()
    h = 0.5 * size
    obj = np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])
    n, rvecs, tvecs, _ = cv2.solvePnPGeneric(
        obj, cv_corners, K, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE
    )
    out = []
    for k in range(int(n)):
        # IPPE's closed form is not the least-squares pose (0.07 px RMS off four exact
        # corners, ~6 mrad of tilt at 0.3 m): Levenberg-Marquardt from it is.
        rvec, tvec = cv2.solvePnPRefineLM(obj, cv_corners, K, dist, rvecs[k], tvecs[k])
        proj = cv2.projectPoints(obj, rvec, tvec, K, dist)[0].reshape(4, 2)
        err = float(np.sqrt(np.mean(np.sum((proj - cv_corners) ** 2, axis=1))))
        T = np.eye(4)
        T[:3, :3] = cv2.Rodrigues(rvec)[0]
        T[:3, 3] = np.asarray(tvec).ravel()
        out.append((T @ _RZ_PI, err))
    return sorted(out, key=lambda p: p[1])


def detect_tags(
    image: NDArray[Any],
    family: str = "36h11",
    *,
    camera: Camera | Optics | None = None,
    tag_size: float | None = None,
    z_aligned: bool = False,
) -> list[TagDetection]:
    """The tags of ``family`` in a grayscale ``image`` (H, W) uint8, sorted by id.

    Args:
        image: 8-bit grayscale image (a colour image (H, W, 3) is converted).
        family: Tag family (:data:`redservo.vision.tag_families.TAG_FAMILIES`; ``"tag36h11"`` also).
        camera: Intrinsics (and distortion) for the pose; None: no pose.
        tag_size: Side of the tag's black square (m); with ``camera``, each tag's pose.
        z_aligned: ViSP's ``setZAlignedWithCameraAxis(true)`` frame (module docstring).

    Returns:
        One :class:`TagDetection` per tag (module docstring for the conventions).

    Raises:
        UnknownNameError: an unknown family.
        ShapeError: ``image`` is not a 2-D (or 3-channel) uint8 array.
        ConfigurationError: ``tag_size`` not positive, or given without ``camera``.
    """
    cv2 = require_cv2()
    fam = check_tag(family)
    img = np.asarray(image)
    if img.dtype != np.uint8 or not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3)):
        raise ShapeError(
            f"image must be a (H, W) or (H, W, 3) uint8 array, got {img.dtype} {img.shape}",
            argument="image",
        )
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    if tag_size is not None:
        try:
            ok = bool(np.isfinite(float(tag_size)) and float(tag_size) > 0.0)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ConfigurationError(f"tag_size must be positive (m), got {tag_size!r}")
        if camera is None:
            raise ConfigurationError("tag_size needs camera (the intrinsics) for a pose")
    K, dist = _intrinsics(camera) if camera is not None else (None, None)
    corners, ids, _ = _detector(fam).detectMarkers(img)
    cells = TAG_FAMILIES[fam][1] + 2
    lens = (K, dist) if K is not None and dist is not None and np.any(dist != 0.0) else None
    out = []
    for c, i in zip(corners, [] if ids is None else ids.ravel()):
        cv_c = refine_quad(img, np.asarray(c, dtype=float).reshape(4, 2), cells, lens)
        poses: list[tuple[FloatArray | None, float]] = [(None, float("nan"))] * 2
        if tag_size is not None and K is not None and dist is not None:
            flip = _RX_PI if z_aligned else np.eye(4)
            found = [(T @ flip, e) for T, e in _pose(cv_c, float(tag_size), K, dist)]
            poses = (found + poses)[:2]
        (cMo, err), (alt, err_alt) = poses
        out.append(TagDetection(int(i), cv_c[_CV_OF] + 0.5, cMo, err, alt, err_alt))
    out.sort(key=lambda d: d.id)
    return out


def iter_tags(
    source: Any,
    family: str = "36h11",
    *,
    camera: Camera | Optics | None = None,
    tag_size: float | None = None,
    max_frames: int | None = None,
) -> Iterator[list[TagDetection]]:
    """:func:`detect_tags` on every frame of ``source`` (anything
    :func:`redservo.vision.sources.frames` reads: a video, an image folder, a camera, a ROS
    bag), one list per frame."""
    from redservo.vision.sources import frames

    for frame in frames(source, max_frames=max_frames):
        yield detect_tags(frame, family, camera=camera, tag_size=tag_size)
