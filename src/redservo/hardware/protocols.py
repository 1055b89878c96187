"""What the servo loop needs from a robot and from a feature source.

Two small :class:`typing.Protocol` classes: implement them for your arm and your
vision pipeline and :class:`~redservo.hardware.ServoLoop` runs any control law on
them (docs/real-robot.md). Nothing here imports a robot SDK or ROS.

Units: seconds (every time stamp on the loop's monotonic clock), metres and radians per joint,
normalized image coordinates for the features (``x = X/Z``).
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

from redservo._validation import FloatArray
from redservo.sensors import NoPose

__all__ = ["FeatureMeasurement", "FeatureSource", "RobotInterface"]


class FeatureMeasurement(NamedTuple):
    """One measurement of the task's features, as a feature source returns it."""

    s: FloatArray
    """(k,) stacked feature values in the task's term order (normalized image units)."""
    inv_depth: tuple[FloatArray, ...]
    """Inverse-depth parameters per task term (1/m), as the controller will use them
    (``1/Ẑ`` for a point; see :mod:`redservo.features.base`)."""
    t_measured: float
    """When the image was taken (s), on the loop's clock (monotonic seconds: convert the
    camera's stamps). The loop uses it to reject stale measurements (``now - t_measured >
    watchdog_timeout``) and to tell a new image from a repeated one (same ``t_measured``).
    A stamp that is not finite, ahead of the loop's clock by more than ``clock_tolerance``
    or earlier than an earlier one is a clock fault: the loop stops the robot
    (:mod:`redservo.hardware.clock`)."""
    no_pose: NoPose | None = None
    """The point set whose PnP pose this image could not give (an image sensor with ``depth =
    "pose"``: its interaction matrices keep the last pose's depths), or None. The loop adds
    the typed flag ``no-pose`` (value: images in a row) to the step that uses this
    measurement (:mod:`redservo.sensors.flags`), so the run's log and summary keep it."""


@runtime_checkable
class RobotInterface(Protocol):
    """A joint-velocity-controlled arm (the hardware side of the loop).

    Each method is called from the loop's thread only. Methods may raise any
    exception on a fault (communication loss, protective stop, ...): the loop then
    calls :meth:`stop` and re-raises it with the iteration in a note.
    """

    def read_joints(self) -> tuple[float, FloatArray]:
        """Return ``(t, q)``: the time stamp of the reading (s, on the loop's monotonic clock)
        and the (n,) joint positions (m or rad). ``t`` must increase with each new reading
        (the same ``t`` again means "no new reading"); with no new reading at most
        ``watchdog_timeout`` old for longer than ``watchdog_timeout``, the run stops
        (``stale_measurement``). A stamp that is not finite, goes backwards or is ahead of
        the loop's clock is a clock fault (:mod:`redservo.hardware.clock`)."""
        ...

    def send_velocity(self, qdot: FloatArray) -> None:
        """Command the (n,) joint velocities ``qdot`` (rad/s or m/s), held until the next call."""
        ...

    def stop(self) -> None:
        """Bring the arm to rest (zero velocity). Must be safe to call at any time, twice."""
        ...


@runtime_checkable
class FeatureSource(Protocol):
    """Where the loop gets the current image features (a tracker, a detector, a simulation)."""

    def measure(self, t: float) -> FeatureMeasurement | None:
        """Return the newest measurement available at loop time ``t`` (s), or None when the
        target is lost (nothing detected). Returning the same measurement again (same
        ``t_measured``) means "no new image yet"."""
        ...
