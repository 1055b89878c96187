"""The camera-motion limit: a command never moves an image point further between two frames
than the tracker follows, nor smears it more than the detector tolerates.

A real camera sees the features at its frame rate, and a tracker finds a dot again only
within a gate around where it was (or where it was predicted to be); a moving camera also
blurs the dot over the exposure. A command ``q̇`` moves image point ``i`` at
``ṡ_i = L_i J q̇`` (``L_i`` its two rows of the interaction matrix, ``J = cVe eJe``;
normalized image units per second), so between two frames, ``T = 1/rate`` apart, it moves
by ``d_i = T ‖ṡ_i‖`` and during the exposure ``τ`` it smears over ``b_i = τ ‖ṡ_i‖``. The
limit keeps

    ``max_i d_i ≤ d_max``  and  ``max_i b_i ≤ b_max``

by scaling the command uniformly by ``σ = min(1, d_max / max_i d_i, b_max / max_i b_i)``.
A uniform scaling towards zero keeps the direction (the law's choice among redundant
motions, hence CM01 eq. 8's joint-limit avoidance), the velocity and the position limits;
the :class:`~redservo.control.Controller` then hands the command to its final guard, which
keeps the acceleration limits (a camera that cannot stop within ``q̈_max dt`` keeps moving,
and the flag says so). ``d_max`` is derived from the tracker's gate:
:meth:`ImageMotionLimit.from_camera`. The predicted motion uses the model ``L`` and ``J``
of the controller (depth estimate included), as any law does.

Units: seconds; image motion in normalized image units (pixels divided by the focal length
in pixels) unless a name says ``_px``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.kernels import flagbits as fb
from redservo.kernels import lazy
from redservo.redundancy.flags import Event
from redservo.redundancy.messages import events

if TYPE_CHECKING:
    from redservo.kernels import image_motion as _K
    from redservo.redundancy.base import Diagnostics
    from redservo.task import VisualTask
else:
    _K = lazy("image_motion")

__all__ = [
    "ImageMotionLimit",
    "check_image_motion",
    "image_motion_scale",
    "limit_image_motion",
    "motion_event",
    "point_rows",
]


def _positive(value: object, name: str, *, allow_inf: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigurationError(f"{name} must be a number, got {value!r}", argument=name)
    v = float(value)
    if not (v > 0.0 and (allow_inf or math.isfinite(v))):
        raise ConfigurationError(f"{name} must be a positive number, got {value!r}", argument=name)
    return v


@dataclass(frozen=True)
class ImageMotionLimit:
    """How far an image point may move between two frames and smear during an exposure.

    Args:
        max_motion: ``d_max``, the largest motion of an image point between two frames
            (normalized image units).
        frame_period: ``T``, the time between two frames (s): ``1/rate``.
        max_blur: ``b_max``, the largest smear of a point during the exposure (normalized
            image units); inf for no blur bound.
        exposure: ``τ``, the exposure time (s); 0 for none.
        focal_px: The focal length in pixels (for the messages only).
    """

    max_motion: float
    frame_period: float
    max_blur: float = math.inf
    exposure: float = 0.0
    focal_px: float = 1.0

    def __post_init__(self) -> None:
        _positive(self.max_motion, "max_motion")
        _positive(self.frame_period, "frame_period")
        _positive(self.max_blur, "max_blur", allow_inf=True)
        _positive(self.focal_px, "focal_px")
        if isinstance(self.exposure, bool) or not (
            isinstance(self.exposure, int | float) and 0.0 <= float(self.exposure) < math.inf
        ):
            raise ConfigurationError(
                f"exposure must be a number >= 0 (s), got {self.exposure!r}", argument="exposure"
            )

    @classmethod
    def from_camera(
        cls,
        *,
        focal_px: float,
        gate_px: float,
        frame_period: float,
        fraction: float = 0.5,
        exposure: float = 0.0,
        max_blur_px: float = math.inf,
    ) -> ImageMotionLimit:
        """The limit of a camera with focal length ``focal_px`` (pixels; the smaller of px and
        py), a tracker that finds a dot within ``gate_px`` pixels of where it was, frames
        ``frame_period`` s apart: a point moves at most ``fraction`` of the gate per frame
        (the rest is the margin for the model's error), and smears at most ``max_blur_px``
        during ``exposure`` s."""
        f = _positive(focal_px, "focal_px")
        gate = _positive(gate_px, "gate_px")
        share = _positive(fraction, "fraction")
        if share > 1.0:
            raise ConfigurationError(
                f"fraction must be in (0, 1], got {fraction!r}", argument="fraction"
            )
        blur = _positive(max_blur_px, "max_blur_px", allow_inf=True)
        return cls(share * gate / f, float(frame_period), blur / f, float(exposure), f)

    @property
    def max_speed(self) -> float:
        """The largest image speed of a point the limit allows (normalized units/s)."""
        speed = self.max_motion / self.frame_period
        if self.exposure > 0.0 and math.isfinite(self.max_blur):
            speed = min(speed, self.max_blur / self.exposure)
        return speed


def image_motion_scale(
    L: FloatArray, J: FloatArray, qdot: FloatArray, rows: FloatArray, limit: ImageMotionLimit
) -> tuple[float, float]:
    """``(σ, fastest)``: the scale in (0, 1] that brings every image point within the limit
    (module docstring) and the fastest point's speed before scaling (normalized units/s).

    Args:
        L: (k, 6) the task's interaction matrix.
        J: (6, n) the robot Jacobian ``cVe eJe``.
        qdot: (n,) the command (rad/s or m/s).
        rows: The first row in ``L`` of each image point's (x, y) pair.
        limit: The camera-motion limit.
    """
    if len(rows) == 0:
        return 1.0, 0.0
    whole = isinstance(rows, np.ndarray) and rows.dtype == np.int64 and rows.ndim == 1
    fastest = -1.0
    if whole and _plain(L, 2) and _plain(J, 2) and _plain(qdot, 1):
        fastest = float(_K.fastest_point(L, J, qdot, rows))  # one compiled call
    if fastest < 0.0:  # not taken, or a row outside L: numpy's code names it
        sdot = L @ (J @ qdot)
        r = np.asarray(rows, dtype=np.intp)
        fastest = float(np.max(np.hypot(sdot[r], sdot[r + 1])))
    if not math.isfinite(fastest):
        return 1.0, fastest  # the guard replaces a non-finite command
    speed = limit.max_speed
    return (1.0, fastest) if fastest <= speed else (speed / fastest, fastest)


def _plain(a: object, ndim: int) -> bool:
    """``a`` is a C-contiguous, aligned float64 array of ``ndim`` dimensions (what
    :func:`redservo.kernels.image_motion.fastest_point` takes)."""
    return (
        isinstance(a, np.ndarray)
        and a.dtype == np.float64
        and a.ndim == ndim
        and a.flags.c_contiguous
        and a.flags.aligned
    )


def motion_event(scale: float, fastest: float, limit: ImageMotionLimit) -> Event:
    """The :data:`~redservo.redundancy.flags.Flag.CAMERA_MOTION_LIMITED` event of a scaling."""
    vals = np.zeros(fb.N_FLAGS)
    src = np.zeros(fb.N_FLAGS, dtype=np.int64)
    vals[fb.CAMERA_MOTION_LIMITED] = scale
    src[fb.CAMERA_MOTION_LIMITED] = fb.ONLY
    motion_px = fastest * limit.frame_period * limit.focal_px
    limit_px = limit.max_motion * limit.focal_px
    (event,) = events(
        1 << fb.CAMERA_MOTION_LIMITED, vals, src, motion_px=motion_px, limit_px=limit_px
    )
    return event


def check_image_motion(limit: object) -> ImageMotionLimit | None:
    """``limit`` if it is an :class:`ImageMotionLimit` or None.

    Raises:
        ConfigurationError: anything else (``argument="image_motion"``).
    """
    if limit is not None and not isinstance(limit, ImageMotionLimit):
        raise ConfigurationError(
            f"image_motion must be an ImageMotionLimit or None, got {limit!r}",
            argument="image_motion",
        )
    return limit


def point_rows(task: VisualTask) -> tuple[int, ...]:
    """The first row of each image point's (x, y) pair in the task's stacked features."""
    from redservo.features import PointFeature

    rows: list[int] = []
    at = 0
    for term in task.terms:
        if isinstance(term.feature, PointFeature):
            rows.append(at)
        at += term.feature.size
    return tuple(rows)


def limit_image_motion(
    qdot: FloatArray,
    diag: Diagnostics,
    L: FloatArray,
    J: FloatArray,
    rows: tuple[int, ...],
    limit: ImageMotionLimit,
) -> tuple[FloatArray, Diagnostics, bool]:
    """``(q̇, diagnostics, scaled)``: the command scaled into the limit (module docstring),
    the diagnostics with a ``camera-motion-limited`` event when it was."""
    scale, fastest = image_motion_scale(L, J, qdot, np.asarray(rows, dtype=np.int64), limit)
    if scale >= 1.0:
        return qdot, diag, False
    event = motion_event(scale, fastest, limit)
    return qdot * scale, dataclasses.replace(diag, events=(*diag.events, event)), True
