"""Real input: frames from a video file, an image folder or a camera, and dots measured in them.

:func:`frames` yields grayscale ``uint8`` frames from

* an ``int`` (or a string of digits): a ``cv2.VideoCapture`` device index
  (``0`` = the first webcam);
* a folder: its image files (``.png .jpg .jpeg .bmp .tif .tiff .pgm .ppm``) in
  name order; each must be a regular file (a FIFO, socket or device named ``a.png`` is an
  error, as it could block forever) of at most
  :data:`~redservo.vision.imagefile.MAX_IMAGE_PIXELS` pixels, checked from its header before
  decoding (:func:`~redservo.vision.imagefile.read_gray`);
* a file with an image suffix: that one image, read as a folder's images are;
* another file: a video read by ``cv2.VideoCapture`` (``.avi``, ``.mp4``, ... whatever
  this OpenCV build decodes), whose frame size (from the container) must not exceed
  ``MAX_IMAGE_PIXELS`` either; a damaged frame keeps its number as a gap and a truncated
  file is reported (:mod:`redservo.vision.capture`);
* an opened ``cv2.VideoCapture``;
* a ROS 1 ``.bag`` file or a ROS 2 bag folder: its first image topic
  (:mod:`redservo.vision.bags`, extra ``redservo[bags]``);
* a list or tuple of images (arrays, or image file paths), or a :class:`FrameList` of
  numbered frames already read.

:func:`track_dots` runs the dot detector and tracker of
:mod:`redservo.vision.dots` on such a source and returns, per frame, the dots
in pixels and in normalized coordinates (through the camera intrinsics and the
distortion), which dots were found, and why not. The dot order is the one of
``initial_uv`` if given, else that of the first frame with exactly ``n_dots``
blobs, sorted top to bottom then left to right (by ``v``, ties by ``u``, in
rows 10 px high). The tracker is :class:`~redservo.vision.tracking.ImageDotTracker`
(per-dot gray levels, re-acquisition after a loss, the reason of each loss).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.vision.bags import bag_frames, is_bag
from redservo.vision.capture import as_gray, read_capture
from redservo.vision.dots import DotTrack, Polarity, detect_dots
from redservo.vision.imagefile import read_gray
from redservo.vision.optics import Optics, require_cv2
from redservo.vision.tracking import ImageDotTracker

__all__ = [
    "IMAGE_SUFFIXES",
    "DotFrame",
    "FrameList",
    "frames",
    "iter_dots",
    "numbered_frames",
    "track_dots",
]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm")
"""Files of an image folder that :func:`frames` reads."""


def _image_files(folder: Path) -> list[Path]:
    """The image files of ``folder`` in name order; each must be a regular file."""
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise ConfigurationError(
            f"{folder}: no image files ({', '.join(IMAGE_SUFFIXES)}) in this folder"
        )
    for f in files:
        try:
            regular = stat.S_ISREG(os.stat(f).st_mode)  # follows symbolic links
        except OSError as exc:
            raise ConfigurationError(f"{f}: cannot read ({exc.strerror})") from None
        if not regular:
            raise ConfigurationError(
                f"{f}: not a regular file (a FIFO, socket, device or folder); an image folder "
                "may hold only regular image files"
            )
    return files


def _listed(
    items: list[Any] | tuple[Any, ...], max_frames: int | None
) -> Iterator[NDArray[np.uint8]]:
    """The images of a list: arrays (gray, BGR or BGRA) or image file paths."""
    for k, item in enumerate(items[:max_frames]):
        if isinstance(item, str | os.PathLike):
            yield read_gray(Path(item))
            continue
        img = np.asarray(item)
        if not (
            img.dtype.kind in "uif"
            and (img.ndim == 2 or (img.ndim == 3 and img.shape[2] in (3, 4)))
            and min(img.shape[:2], default=0) > 0
        ):
            raise ConfigurationError(
                f"source[{k}]: expected an image (a 2-D gray or 3-D BGR/BGRA numeric array) "
                f"or an image file path, got {type(item).__name__} of shape {img.shape}",
                argument="source",
            )
        yield as_gray(img)


class FrameList(list[tuple[int, NDArray[np.uint8]]]):
    """Frames already read, with their numbers: ``(frame number, (H, W) uint8)`` pairs, e.g.
    ``FrameList(numbered_frames(video))``; as a source, the numbers are kept (gaps too)."""


def numbered_frames(
    source: Any, *, max_frames: int | None = None
) -> Iterator[tuple[int, NDArray[np.uint8]]]:
    """Yield ``(frame number, grayscale frame (H, W) uint8)`` of ``source`` (module docstring).

    The numbers count from 0 and skip the frames of a video that could not be decoded
    (:mod:`redservo.vision.capture`: the later frames keep their numbers, and a
    :class:`~redservo.vision.capture.VideoWarning` at the end names the skipped ones and
    compares the frames read with the container's count).

    Args:
        source: Device index, folder, image or video file, ROS bag, an opened
            ``cv2.VideoCapture``, or a list of images (arrays or image file paths).
        max_frames: Stop after this many frames (None = all; a camera never ends).

    Raises:
        ConfigurationError: the source does not exist, holds no image, cannot be opened, not
            one frame of a video decodes, a folder holds something other than regular files
            under an image name, a list holds something other than images, or an image is
            larger than ``MAX_IMAGE_PIXELS`` (the message names the file).
    """
    cv2 = require_cv2()
    if max_frames is not None and not (
        isinstance(max_frames, int | np.integer) and max_frames >= 1
    ):
        raise ConfigurationError(
            f"max_frames must be a positive integer or None, got {max_frames!r}"
        )
    if isinstance(source, cv2.VideoCapture):
        yield from read_capture(source, "the given capture", max_frames)
        return
    if isinstance(source, int) or (isinstance(source, str) and source.isdigit()):
        cap = cv2.VideoCapture(int(source))
        yield from read_capture(cap, f"camera device {source}", max_frames, video=False)
        return
    if isinstance(source, FrameList):
        yield from (item for item in source if max_frames is None or item[0] < max_frames)
        return
    if isinstance(source, list | tuple):
        yield from enumerate(_listed(source, max_frames))
        return
    path = Path(source)
    if is_bag(path):  # a ROS 1 .bag or a ROS 2 bag folder: redservo.vision.bags
        yield from enumerate(bag_frames(path, max_frames=max_frames))
        return
    if path.is_dir():
        yield from enumerate(read_gray(f) for f in _image_files(path)[:max_frames])
        return
    if not path.is_file():
        raise ConfigurationError(
            f"{path}: no such file or folder (a source is a video file, an image folder "
            "or a camera index)"
        )
    if path.suffix.lower() in IMAGE_SUFFIXES:  # one image, read safely (imagefile)
        yield 0, read_gray(path)
        return
    yield from read_capture(cv2.VideoCapture(str(path)), f"video file {path}", max_frames)


def frames(source: Any, *, max_frames: int | None = None) -> Iterator[NDArray[np.uint8]]:
    """Yield the grayscale frames (H, W) uint8 of ``source``: :func:`numbered_frames` without
    the numbers (same arguments and errors)."""
    for _, img in numbered_frames(source, max_frames=max_frames):
        yield img


class DotFrame(NamedTuple):
    """The dots measured in one frame."""

    frame: int
    """Frame number (0-based)."""
    uv: FloatArray
    """(N, 2) dot positions (pixels); NaN before the tracker started; predictions for lost dots."""
    xy: FloatArray
    """(N, 2) the same in undistorted normalized coordinates (the point features ``(x, y)``)."""
    detected: NDArray[np.bool_]
    """(N,) dots found in this frame."""
    n_blobs: int
    """Blobs found in the frame."""
    reason: str
    """What went wrong (wrong number of blobs, lost dots), empty when all is well."""
    reasons: tuple[str, ...] = ()
    """Per dot, why it was lost in this frame (:data:`redservo.vision.tracking.LOSS_REASONS`;
    ``""`` when found); empty before the tracker started."""


_DAMAGED = "damaged: the frame could not be decoded (no measurement; its number is kept)"


def _initial_order(uv: FloatArray) -> FloatArray:
    order = np.lexsort((uv[:, 0], np.floor(uv[:, 1] / 10.0)))
    return uv[order]


def track_dots(source: Any, n_dots: int | None = None, **options: Any) -> list[DotFrame]:
    """Detect and track dots in every frame of ``source``; one :class:`DotFrame` per frame.

    The list of :func:`iter_dots` (same arguments).
    """
    return list(iter_dots(source, n_dots, **options))


def iter_dots(
    source: Any,
    n_dots: int | None = None,
    *,
    camera: Camera | None = None,
    distortion: float | tuple[float, float] = 0.0,
    threshold: float | str = "otsu",
    polarity: Polarity = "bright",
    initial_uv: ArrayLike | None = None,
    min_size_px: float = 2.0,
    max_size_px: float = 30.0,
    max_jump_px: float = 25.0,
    max_lost_frames: int = 3,
    max_frames: int | None = None,
) -> Iterator[DotFrame]:
    """Detect and track dots in each frame of ``source``, yielding a :class:`DotFrame` per frame.

    Args:
        source: See :func:`frames`.
        n_dots: Number of dots; default the number in ``initial_uv``, else in the first frame.
        camera: Intrinsics (default :class:`~redservo.camera.Camera`; its size is not checked
            against the frames).
        distortion: Radial distortion ``k1`` or ``(k1, k2)``.
        threshold: Gray level or ``"otsu"`` (per frame).
        polarity: ``"bright"`` or ``"dark"`` dots.
        initial_uv: (N, 2) initial dot positions (pixels), fixing the order.
        min_size_px: Smallest dot (bounding-box size, pixels).
        max_size_px: Largest dot.
        max_jump_px: Largest motion (pixels) of a dot between frames, after prediction.
        max_lost_frames: A dot lost for more consecutive frames is reported gone.
        max_frames: Stop after this many frames.
    """
    if n_dots is not None and not (isinstance(n_dots, int | np.integer) and n_dots >= 1):
        raise ConfigurationError(f"n_dots must be a positive integer or None, got {n_dots!r}")
    if not (np.isfinite(min_size_px) and 0.0 < min_size_px <= max_size_px < np.inf):
        raise ConfigurationError(
            "the dot sizes must be finite with 0 < min_size_px <= max_size_px, got "
            f"min_size_px = {min_size_px!r}, max_size_px = {max_size_px!r}"
        )
    k = np.atleast_1d(np.asarray(distortion, dtype=float))
    optics = Optics(camera or Camera(), float(k[0]), float(k[1]) if k.size > 1 else 0.0)
    init = None if initial_uv is None else np.asarray(initial_uv, dtype=float).reshape(-1, 2)
    if n_dots is None and init is not None:
        n_dots = init.shape[0]
    tracker: ImageDotTracker | None = None
    expected = 0
    for i, img in numbered_frames(source, max_frames=max_frames):
        for gap in range(expected, i):  # frames of a video that could not be decoded
            n = tracker.n_dots if tracker is not None else max(n_dots or 0, 0)
            nan = np.full((n, 2), np.nan)
            yield DotFrame(gap, nan, nan.copy(), np.zeros(n, bool), 0, _DAMAGED)
        expected = i + 1
        det = detect_dots(
            img,
            threshold=threshold,
            polarity=polarity,
            min_size_px=min_size_px,
            max_size_px=max_size_px,
        )
        m = det.uv.shape[0]
        if tracker is None:
            want = m if n_dots is None else n_dots
            if init is None and (m != want or m == 0):
                nan = np.full((max(want, 0), 2), np.nan)
                reason = f"waiting for a frame with exactly {want} dots (found {m})"
                yield DotFrame(i, nan, nan.copy(), np.zeros(len(nan), bool), m, reason)
                continue
            tracker = ImageDotTracker(
                want, polarity, max_jump_px, max_lost_frames, min_size_px, max_size_px
            )
            track = tracker.start(img, init if init is not None else _initial_order(det.uv))
        else:
            track = tracker.update(img)
        notes = _notes(track, m, tracker.n_dots, max_lost_frames)
        xy = optics.to_normalized(track.uv)
        yield DotFrame(i, track.uv, xy, track.detected, m, notes, track.reasons)


def _notes(track: DotTrack, m: int, n_dots: int, max_lost_frames: int) -> str:
    """What went wrong in a frame: blob count, lost dots with their reasons, gone dots."""
    notes = []
    if m != n_dots:
        notes.append(f"found {m} blob(s), expected {n_dots}")
    missing = np.flatnonzero(~track.detected)
    if missing.size:
        why = ", ".join(f"{int(j)} ({track.reasons[j]})" for j in missing)
        notes.append(f"dot(s) {why} lost")
    if track.gone:
        notes.append(
            f"feature_lost: dot(s) {', '.join(map(str, track.gone))} lost for more than "
            f"{max_lost_frames} frame(s)"
        )
    return "; ".join(notes)
