"""The error of a ROS 2 message redservo cannot use."""

from __future__ import annotations

from redservo.errors import RedservoError

__all__ = ["MessageError"]


class MessageError(RedservoError, ValueError):
    """A ROS 2 message that breaks what redservo needs (a ``JointState`` without one of the
    joints or with NaN, an ``Image`` of an unknown encoding or of the wrong size), or a topic
    that stays silent. The message names the topic; ``argument`` is the topic name. Raised
    from the robot interface or the feature source, it stops the arm (the servo loop stops
    the robot, then re-raises it)."""
