# mypy: disable-error-code="type-arg,valid-type,assignment"
"""The ROS 2 messages redservo reads and publishes, as Cyclone DDS IDL types.

Each class serializes to the same CDR bytes as ROS 2 (Humble and Jazzy) does for the
message of the same name (tests/test_ros2_wire.py checks this against ``rosbags``). Field
names and order follow the ``.msg`` definitions; the DDS type names come from
:func:`redservo.ros2.naming.dds_type_name`.

Needs the ``ros2`` extra (``pip install 'redservo[ros2]'``: ``cyclonedds``).

Units: as in ROS 2 (``Time``: seconds and nanoseconds since the epoch of the publisher's
clock; ``JointState``: rad or m, rad/s or m/s, N·m or N; ``CameraInfo``: pixels).
"""

# No "from __future__ import annotations": cyclonedds resolves the field types at run time.

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import int32, uint8, uint32

if TYPE_CHECKING:  # cyclonedds' annotation types are not generic for mypy
    sequence = list
    array = list
    float64 = float
    octets = bytes
else:
    from cyclonedds.idl.types import array, float64, sequence

    octets = sequence[uint8]  # read and written as bytes: _bytes_field

from redservo.ros2.naming import dds_type_name

__all__ = [
    "MESSAGE_TYPES",
    "CameraInfo",
    "Float64MultiArray",
    "Header",
    "Image",
    "JointState",
    "MultiArrayDimension",
    "MultiArrayLayout",
    "RegionOfInterest",
    "Time",
    "seconds_to_time",
    "time_to_seconds",
]


@dataclass
class Time(IdlStruct, typename=dds_type_name("builtin_interfaces/msg/Time")):
    """``builtin_interfaces/msg/Time``."""

    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Header(IdlStruct, typename=dds_type_name("std_msgs/msg/Header")):
    """``std_msgs/msg/Header``."""

    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class JointState(IdlStruct, typename=dds_type_name("sensor_msgs/msg/JointState")):
    """``sensor_msgs/msg/JointState``."""

    header: Header = field(default_factory=Header)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


@dataclass
class MultiArrayDimension(IdlStruct, typename=dds_type_name("std_msgs/msg/MultiArrayDimension")):
    """``std_msgs/msg/MultiArrayDimension``."""

    label: str = ""
    size: uint32 = 0
    stride: uint32 = 0


@dataclass
class MultiArrayLayout(IdlStruct, typename=dds_type_name("std_msgs/msg/MultiArrayLayout")):
    """``std_msgs/msg/MultiArrayLayout``."""

    dim: sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: uint32 = 0


@dataclass
class Float64MultiArray(IdlStruct, typename=dds_type_name("std_msgs/msg/Float64MultiArray")):
    """``std_msgs/msg/Float64MultiArray`` (what a ros2_control ``JointGroupVelocityController``
    takes on ``/<controller>/commands``)."""

    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: sequence[float64] = field(default_factory=list)


@dataclass
class Image(IdlStruct, typename=dds_type_name("sensor_msgs/msg/Image")):
    """``sensor_msgs/msg/Image``."""

    header: Header = field(default_factory=Header)
    height: uint32 = 0
    width: uint32 = 0
    encoding: str = ""
    is_bigendian: uint8 = 0
    step: uint32 = 0
    data: octets = field(default_factory=bytes)
    """The pixels: ``bytes`` (:func:`_bytes_field`)."""


@dataclass
class RegionOfInterest(IdlStruct, typename=dds_type_name("sensor_msgs/msg/RegionOfInterest")):
    """``sensor_msgs/msg/RegionOfInterest``."""

    x_offset: uint32 = 0
    y_offset: uint32 = 0
    height: uint32 = 0
    width: uint32 = 0
    do_rectify: bool = False


def _bytes_field(cls: type[IdlStruct], name: str) -> None:
    """Read and write ``cls.name`` (a ``sequence<uint8>``) as ``bytes``, not a list of ints.

    Same CDR bytes (a uint32 length then the octets) and the same XTypes type (built from
    the annotation), but a 640 x 480 rgb8 image serializes in ~3 ms instead of ~70 ms.
    Uses cyclonedds' internal machines (checked by tests/test_ros2_wire.py); when they are
    not where expected, the field stays a list of ints (slower, equally correct).
    """
    from cyclonedds.idl._machinery import BytesMachine

    idl = getattr(cls, "__idl__", None)
    try:
        idl.populate()  # type: ignore[union-attr]
        for machine in (idl.v1_machine, idl.v2_machine):  # type: ignore[union-attr]
            if name in machine.members_machines:
                machine.members_machines[name] = BytesMachine()
    except AttributeError:  # pragma: no cover - another cyclonedds layout
        return


def _zeros(n: int) -> list[float]:
    return [0.0] * n


@dataclass
class CameraInfo(IdlStruct, typename=dds_type_name("sensor_msgs/msg/CameraInfo")):
    """``sensor_msgs/msg/CameraInfo`` (Humble and later field names: ``d``, ``k``, ``r``, ``p``)."""

    header: Header = field(default_factory=Header)
    height: uint32 = 0
    width: uint32 = 0
    distortion_model: str = ""
    d: sequence[float64] = field(default_factory=list)
    k: array[float64, 9] = field(default_factory=lambda: _zeros(9))
    r: array[float64, 9] = field(default_factory=lambda: _zeros(9))
    p: array[float64, 12] = field(default_factory=lambda: _zeros(12))
    binning_x: uint32 = 0
    binning_y: uint32 = 0
    roi: RegionOfInterest = field(default_factory=RegionOfInterest)


_bytes_field(Image, "data")

MESSAGE_TYPES: dict[str, type[IdlStruct]] = {
    "builtin_interfaces/msg/Time": Time,
    "std_msgs/msg/Header": Header,
    "sensor_msgs/msg/JointState": JointState,
    "std_msgs/msg/MultiArrayDimension": MultiArrayDimension,
    "std_msgs/msg/MultiArrayLayout": MultiArrayLayout,
    "std_msgs/msg/Float64MultiArray": Float64MultiArray,
    "sensor_msgs/msg/Image": Image,
    "sensor_msgs/msg/RegionOfInterest": RegionOfInterest,
    "sensor_msgs/msg/CameraInfo": CameraInfo,
}
"""Every ROS 2 message type redservo uses, by its ROS name."""


def time_to_seconds(stamp: Time) -> float:
    """A ``Time`` as seconds (float) since its clock's epoch."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def seconds_to_time(seconds: float) -> Time:
    """Seconds since the epoch as a ``Time`` (``nanosec`` in [0, 1e9), rounded to 1 ns)."""
    if not math.isfinite(seconds):
        return Time(0, 0)
    sec = math.floor(seconds)
    nanosec = round((seconds - sec) * 1e9)  # the fraction alone: no loss at epoch magnitudes
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return Time(int(sec), int(nanosec))
