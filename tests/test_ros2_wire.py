"""ROS 2 wire compatibility (issue 31): every message type redservo reads or publishes
serializes to the same CDR bytes as ROS 2 Humble and Jazzy (``rosbags``' serializers), and
reads back from them; ROS 2 naming rules."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

pytest.importorskip("cyclonedds")
rosbags_typesys = pytest.importorskip("rosbags.typesys")

from redservo.errors import ConfigurationError  # noqa: E402
from redservo.ros2 import messages as m  # noqa: E402
from redservo.ros2.naming import dds_topic, dds_type_name, validate_topic  # noqa: E402

ROS_NAME = {cls: name for name, cls in m.MESSAGE_TYPES.items()}
ARRAY_DTYPE = {"data": None, "position": float, "velocity": float, "effort": float}
STORES = [rosbags_typesys.Stores.ROS2_HUMBLE, rosbags_typesys.Stores.ROS2_JAZZY]


def _text(rng: np.random.Generator) -> str:
    return "".join(rng.choice(list("abcxyz_/é0129 "), size=int(rng.integers(0, 12))))


def _floats(rng: np.random.Generator, n: int | None = None) -> list[float]:
    count = int(rng.integers(0, 9)) if n is None else n
    return [float(v) for v in rng.normal(0.0, 100.0, count)]


def random_message(cls: type, rng: np.random.Generator) -> Any:
    """A message of type ``cls`` with random field values (nested types random too)."""
    u32 = lambda: int(rng.integers(0, 2**32))  # noqa: E731
    if cls is m.Time:
        return m.Time(int(rng.integers(-(2**31), 2**31)), u32())
    if cls is m.Header:
        return m.Header(random_message(m.Time, rng), _text(rng))
    if cls is m.JointState:
        n = int(rng.integers(0, 8))
        names = [_text(rng) for _ in range(n)]
        return m.JointState(
            random_message(m.Header, rng), names, _floats(rng, n), _floats(rng), _floats(rng)
        )
    if cls is m.MultiArrayDimension:
        return m.MultiArrayDimension(_text(rng), u32(), u32())
    if cls is m.MultiArrayLayout:
        dims = [random_message(m.MultiArrayDimension, rng) for _ in range(rng.integers(0, 3))]
        return m.MultiArrayLayout(dims, u32())
    if cls is m.Float64MultiArray:
        return m.Float64MultiArray(random_message(m.MultiArrayLayout, rng), _floats(rng))
    if cls is m.Image:
        data = rng.integers(0, 256, int(rng.integers(0, 50))).astype(np.uint8).tobytes()
        return m.Image(
            random_message(m.Header, rng),
            u32(),
            u32(),
            _text(rng),
            int(rng.integers(0, 2)),
            u32(),
            data,
        )
    if cls is m.RegionOfInterest:
        return m.RegionOfInterest(u32(), u32(), u32(), u32(), bool(rng.integers(0, 2)))
    assert cls is m.CameraInfo
    return m.CameraInfo(
        random_message(m.Header, rng),
        u32(),
        u32(),
        _text(rng),
        _floats(rng),
        _floats(rng, 9),
        _floats(rng, 9),
        _floats(rng, 12),
        u32(),
        u32(),
        random_message(m.RegionOfInterest, rng),
    )


def to_rosbags(msg: Any, store: Any) -> Any:
    """The same message as a ``rosbags`` object of ``store`` (numpy arrays for numbers)."""
    ros_cls = store.types[ROS_NAME[type(msg)]]
    values: dict[str, Any] = {}
    for f in dataclasses.fields(msg):
        v = getattr(msg, f.name)
        if isinstance(v, bytes):
            v = np.frombuffer(v, dtype=np.uint8)
        elif type(v) in ROS_NAME:
            v = to_rosbags(v, store)
        elif isinstance(v, list) and (not v or not isinstance(v[0], str)):
            if v and type(v[0]) in ROS_NAME:
                v = [to_rosbags(x, store) for x in v]
            else:
                v = np.array(v, dtype=np.float64)
        values[f.name] = v
    return ros_cls(**values)


@pytest.mark.parametrize("store_name", STORES, ids=lambda s: s.name)
@pytest.mark.parametrize("ros_name", sorted(m.MESSAGE_TYPES))
def test_cdr_bytes_match_ros2(store_name: Any, ros_name: str) -> None:
    store = rosbags_typesys.get_typestore(store_name)
    cls = m.MESSAGE_TYPES[ros_name]
    rng = np.random.default_rng(abs(hash((ros_name, store_name.name))) % 2**32)
    for _ in range(25):
        msg = random_message(cls, rng)
        ours = bytes(msg.serialize())
        theirs = bytes(store.serialize_cdr(to_rosbags(msg, store), ros_name))
        assert ours == theirs, (ros_name, msg)
        assert cls.deserialize(theirs) == msg


def test_dds_type_names_follow_ros2() -> None:
    assert dds_type_name("sensor_msgs/msg/JointState") == "sensor_msgs::msg::dds_::JointState_"
    assert m.Float64MultiArray.__idl_typename__ == "std_msgs::msg::dds_::Float64MultiArray_"
    assert dds_topic("/forward_velocity_controller/commands") == (
        "rt/forward_velocity_controller/commands"
    )


@pytest.mark.parametrize(
    "bad",
    ["", "joint_states", "/", "/a//b", "/a/", "/1a", "/a b", "/a-b", "/~a", 3, "/" + "a" * 250],
)
def test_topic_names_ros2_would_refuse_are_one_error_naming_the_key(bad: Any) -> None:
    with pytest.raises(ConfigurationError, match=r"robot\.command") as err:
        validate_topic(bad, "robot.command")
    assert err.value.argument == "robot.command"


def test_stamp_conversion_round_trips() -> None:
    t = m.seconds_to_time(1_700_000_000.25)  # exact in binary: no rounding
    assert (t.sec, t.nanosec) == (1_700_000_000, 250_000_000)
    assert m.time_to_seconds(t) == 1_700_000_000.25
    assert m.seconds_to_time(-0.5) == m.Time(-1, 500_000_000)


def test_image_pixels_travel_as_bytes() -> None:
    img = m.Image(encoding="mono8", height=1, width=3, step=3, data=b"\x01\x02\x03")
    back = m.Image.deserialize(img.serialize())
    assert isinstance(back.data, bytes) and back == img
