"""Frames of a ``cv2.VideoCapture`` (a video file or a camera), numbered as the container numbers
them, with what could not be read reported rather than lost silently.

``cap.read()`` returns False both at the end of a video and on a frame it cannot decode (a
damaged JPEG in an MJPG file), and a truncated file simply ends early. So for a video file,
:func:`read_capture`

* keeps reading after a failed frame while the container announces more frames
  (``CAP_PROP_FRAME_COUNT``): a damaged frame becomes a *gap*, its number skipped, and the
  next frame keeps its own number (no shift of the later frames);
* stops after :data:`MAX_BAD_RUN` failures in a row, or at the announced count;
* at the end, warns (:class:`VideoWarning`) with the frames read against the container's
  count and the numbers of the damaged frames (a truncated file, a damaged frame);
* raises :class:`~redservo.errors.ConfigurationError` when not one frame can be decoded
  (a file that is not a video, or one damaged from its start).

A camera has no count: its stream ends at the first failed read.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo.errors import ConfigurationError
from redservo.vision.imagefile import check_frame_size
from redservo.vision.optics import require_cv2

__all__ = ["MAX_BAD_RUN", "CaptureReport", "VideoWarning", "as_gray", "read_capture"]

MAX_BAD_RUN = 100
"""Failed reads in a row after which a video is taken to end (truncated) rather than to hold
damaged frames."""


class VideoWarning(UserWarning):
    """A video was read only in part: fewer frames than its container announces, or frames
    that could not be decoded (their numbers are in the message)."""


@dataclass
class CaptureReport:
    """What :func:`read_capture` read from one capture."""

    what: str
    """The source's name (e.g. ``video file clip.avi``)."""
    announced: int | None
    """Frames the container announces (``CAP_PROP_FRAME_COUNT``), None when unknown."""
    expected: int | None = None
    """Frames that should have been read: ``announced``, at most ``max_frames``."""
    read: int = 0
    """Frames decoded."""
    damaged: list[int] = field(default_factory=list)
    """Numbers (0-based) of the frames that could not be decoded, followed by good ones."""

    def problem(self) -> str:
        """What went wrong, "" when every announced frame was read."""
        notes = []
        if self.expected is not None and self.read + len(self.damaged) < self.expected:
            of = f"the {self.announced} frames its container announces"
            if self.expected != self.announced:
                of = f"the {self.expected} frames asked for ({self.announced} in the container)"
            notes.append(f"read {self.read} of {of} (a truncated or damaged file?)")
        if self.damaged:
            shown = ", ".join(map(str, self.damaged[:20])) + (
                ", ..." if len(self.damaged) > 20 else ""
            )
            notes.append(
                f"{len(self.damaged)} frame(s) could not be decoded and were skipped, "
                f"keeping the numbers of the others: {shown}"
            )
        return f"{self.what}: " + "; ".join(notes) if notes else ""


def as_gray(frame: NDArray[Any]) -> NDArray[np.uint8]:
    """A frame as a contiguous (H, W) uint8 image (BGR converted, other depths scaled)."""
    cv2 = require_cv2()
    if frame.ndim == 3:
        code = cv2.COLOR_BGRA2GRAY if frame.shape[2] == 4 else cv2.COLOR_BGR2GRAY
        frame = cv2.cvtColor(frame, code)
    if frame.dtype != np.uint8:
        frame = cv2.convertScaleAbs(frame, alpha=255.0 / max(float(frame.max()), 1.0))
    return np.ascontiguousarray(frame)


def read_capture(
    cap: Any, what: str, max_frames: int | None, *, video: bool = True
) -> Iterator[tuple[int, NDArray[np.uint8]]]:
    """``(frame number, grayscale frame)`` of ``cap`` (module docstring); released at the end.

    Args:
        cap: An opened or unopened ``cv2.VideoCapture``.
        what: Its name in messages.
        max_frames: Stop after this many frame numbers (None = all).
        video: A file with a frame count (gaps and truncation reported), else a camera.

    Raises:
        ConfigurationError: it cannot be opened, its frames exceed the size cap, or not one
            frame of a video file can be decoded.
    """
    if not cap.isOpened():
        raise ConfigurationError(f"cannot open {what} with cv2.VideoCapture")
    cv2 = require_cv2()
    try:
        w = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
        h = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        check_frame_size(max(w, 0), max(h, 0), what)
        count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if video else 0
        report = CaptureReport(what, count if count > 0 else None)
        if report.announced is not None:
            report.expected = min(report.announced, max_frames or report.announced)
        k, failed = 0, []
        while max_frames is None or k < max_frames:
            ok, frame = cap.read()
            if not ok or frame is None:
                if report.announced is None or k >= report.announced:
                    break
                failed.append(k)
                k += 1
                if len(failed) > MAX_BAD_RUN:
                    break
                continue
            report.damaged += failed
            failed = []
            report.read += 1
            yield k, as_gray(frame)
            k += 1
    finally:
        cap.release()
    _conclude(report, video)


def _conclude(report: CaptureReport, video: bool) -> None:
    if video and report.read == 0:
        raise ConfigurationError(
            f"{report.what}: not one frame could be decoded (not a video, or damaged from its "
            "start)"
        )
    problem = report.problem()
    if video and problem:
        warnings.warn(problem, VideoWarning, stacklevel=3)
