"""ROS 2 naming conventions on the DDS wire, in one place.

ROS 2 (through ``rmw_cyclonedds`` and ``rmw_fastrtps``) maps a ROS topic ``/joint_states`` to
the DDS topic ``rt/joint_states`` and a message type ``sensor_msgs/msg/JointState`` to the
DDS type name ``sensor_msgs::msg::dds_::JointState_``. A node that follows these rules is
seen by ``ros2 topic list`` and talks to any ROS 2 node on the same domain.

Topic names here are *fully qualified* (they start with ``/``): redservo is not a ROS node
and has no namespace to resolve a relative name against.
"""

from __future__ import annotations

import re

from redservo.errors import ConfigurationError

__all__ = ["MAX_TOPIC_LENGTH", "dds_topic", "dds_type_name", "validate_topic"]

TOPIC_PREFIX = "rt"
"""The prefix of every ROS 2 topic on DDS (``rt/``: ROS topic)."""

MAX_TOPIC_LENGTH = 247
"""Longest fully qualified ROS 2 topic name (characters): ``rmw``'s 255 minus the prefix room."""

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def validate_topic(name: object, key: str) -> str:
    """Return ``name`` when ROS 2 accepts it as a fully qualified topic name.

    The rules of ``rmw_validate_full_topic_name``: starts with ``/``, tokens separated by
    single ``/`` made of letters, digits and ``_``, no token starting with a digit, no
    trailing ``/``, at most :data:`MAX_TOPIC_LENGTH` characters.

    Args:
        name: The topic name.
        key: What to name in the error (a hardware-file key or an argument).

    Raises:
        ConfigurationError: ``name`` is not a string ROS 2 would accept (``argument=key``).
    """
    allowed = (
        "a fully qualified ROS 2 topic name: '/' then tokens of letters, digits and '_' "
        "separated by single '/', no token starting with a digit, no trailing '/'"
    )
    if not isinstance(name, str):
        raise ConfigurationError(f"{key} must be {allowed}, got {name!r}", argument=key)
    tokens = name[1:].split("/") if name.startswith("/") else []
    if not tokens or not all(_TOKEN.fullmatch(t) for t in tokens):
        raise ConfigurationError(f"{key} = {name!r} is not {allowed}", argument=key)
    if len(name) > MAX_TOPIC_LENGTH:
        raise ConfigurationError(
            f"{key} = {name[:40]!r}... is {len(name)} characters; ROS 2 allows at most "
            f"{MAX_TOPIC_LENGTH}",
            argument=key,
        )
    return name


def dds_topic(name: str) -> str:
    """The DDS topic of the ROS 2 topic ``name`` (``/joint_states`` -> ``rt/joint_states``)."""
    return TOPIC_PREFIX + validate_topic(name, "topic")


def dds_type_name(ros_type: str) -> str:
    """The DDS type name of a ROS 2 message type.

    ``sensor_msgs/msg/JointState`` -> ``sensor_msgs::msg::dds_::JointState_``.
    """
    package, kind, name = ros_type.split("/")
    return f"{package}::{kind}::dds_::{name}_"
