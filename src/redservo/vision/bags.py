"""Recorded ROS 1 and ROS 2 bags as a frame source, read without ROS (extra ``redservo[bags]``).

:func:`bag_frames` yields the grayscale frames of a ``sensor_msgs/Image`` (encodings ``mono8``,
``mono16``, ``bgr8``, ``rgb8``, ``bgra8``, ``rgba8``) or ``sensor_msgs/CompressedImage`` topic;
:func:`bag_camera` reads the intrinsics and distortion of a ``sensor_msgs/CameraInfo`` topic
(``K``, ``D`` with the ``plumb_bob`` or ``rational_polynomial`` model: the first five of ``D``
are OpenCV's ``k1, k2, p1, p2, k3``); :func:`bag_joint_states` the joint positions of a
``sensor_msgs/JointState`` topic. All through the ``rosbags`` package (pure Python), which reads
ROS 1 ``.bag`` files and ROS 2 bag folders (``metadata.yaml`` with ``.db3`` or ``.mcap``).
:func:`redservo.vision.sources.frames` hands a bag to :func:`bag_frames`.

Without ``topic`` the first topic of the wanted type is used; a bag with none raises
:class:`~redservo.errors.ConfigurationError` naming the topics it has.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.vision.optics import require_cv2

__all__ = ["bag_camera", "bag_frames", "bag_joint_states", "is_bag"]

_IMAGE = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")


def is_bag(source: Any) -> bool:
    """Whether ``source`` names a ROS 1 bag file or a ROS 2 bag folder."""
    if not isinstance(source, str | Path):
        return False
    p = Path(source)
    return (p.is_file() and p.suffix == ".bag") or (p.is_dir() and (p / "metadata.yaml").is_file())


def _reader(path: str | Path) -> Any:
    try:
        from rosbags.highlevel import AnyReader
    except ImportError as exc:  # pragma: no cover - the extra is installed in CI
        raise ConfigurationError(
            f"reading a ROS bag needs rosbags: pip install 'redservo[bags]' ({exc})"
        ) from None
    return AnyReader([Path(path)])


def _connections(reader: Any, types: tuple[str, ...], topic: str | None, path: Any) -> list[Any]:
    conns = [c for c in reader.connections if c.msgtype in types]
    if topic is not None:
        conns = [c for c in conns if c.topic == topic]
    if not conns:
        have = ", ".join(sorted(f"{c.topic} ({c.msgtype})" for c in reader.connections)) or "none"
        what = f"topic {topic!r} of type" if topic else "a topic of type"
        raise ConfigurationError(f"{path}: no {what} {' or '.join(types)}; its topics: {have}")
    return [c for c in conns if c.topic == conns[0].topic]


def _gray(msg: Any, msgtype: str) -> NDArray[np.uint8]:
    cv2 = require_cv2()
    if msgtype.endswith("CompressedImage"):
        img = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise ConfigurationError(f"cannot decode a compressed image ({msg.format!r})")
        return np.asarray(img, dtype=np.uint8)
    enc = str(msg.encoding).lower()
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    data = np.frombuffer(bytes(msg.data), np.uint8)
    channels = {"mono8": 1, "8uc1": 1, "bgr8": 3, "rgb8": 3, "bgra8": 4, "rgba8": 4}
    if enc in ("mono16", "16uc1"):
        dt = np.dtype(">u2" if msg.is_bigendian else "<u2")
        img16 = np.frombuffer(bytes(msg.data), dt).reshape(h, step // 2)[:, :w]
        return np.asarray(img16 >> 8, dtype=np.uint8)
    if enc not in channels:
        raise ConfigurationError(
            f"image encoding {msg.encoding!r} is not supported; allowed: "
            f"{', '.join([*channels, 'mono16', '16uc1'])}"
        )
    c = channels[enc]
    img = data.reshape(h, step)[:, : w * c].reshape(h, w, c)
    if c == 1:
        return np.ascontiguousarray(img[..., 0])
    code = {
        "bgr8": cv2.COLOR_BGR2GRAY,
        "rgb8": cv2.COLOR_RGB2GRAY,
        "bgra8": cv2.COLOR_BGRA2GRAY,
        "rgba8": cv2.COLOR_RGBA2GRAY,
    }[enc]
    return np.asarray(cv2.cvtColor(np.ascontiguousarray(img), code), dtype=np.uint8)


def bag_frames(
    path: str | Path, *, topic: str | None = None, max_frames: int | None = None
) -> Iterator[NDArray[np.uint8]]:
    """The grayscale frames (H, W) uint8 of an image topic, in time order."""
    with _reader(path) as reader:
        conns = _connections(reader, _IMAGE, topic, path)
        for k, (conn, _, raw) in enumerate(reader.messages(connections=conns)):
            if max_frames is not None and k >= max_frames:
                break
            yield _gray(reader.deserialize(raw, conn.msgtype), conn.msgtype)


def bag_camera(path: str | Path, *, topic: str | None = None) -> Camera:
    """The camera of the first ``CameraInfo`` message: intrinsics, size, distortion."""
    with _reader(path) as reader:
        conns = _connections(reader, ("sensor_msgs/msg/CameraInfo",), topic, path)
        for conn, _, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            K = np.asarray(msg.k if hasattr(msg, "k") else msg.K, dtype=float).reshape(3, 3)
            D = list(np.asarray(msg.d if hasattr(msg, "d") else msg.D, dtype=float)) + [0.0] * 5
            k1, k2, p1, p2, k3 = D[:5]
            # ROS puts pixel centres on the integers (as OpenCV); redservo on the half-integers
            return Camera(
                float(K[0, 0]),
                float(K[1, 1]),
                float(K[0, 2]) + 0.5,
                float(K[1, 2]) + 0.5,
                int(msg.width),
                int(msg.height),
                k1=k1,
                k2=k2,
                p1=p1,
                p2=p2,
                k3=k3,
            )
    raise ConfigurationError(f"{path}: the CameraInfo topic has no message")


def bag_joint_states(
    path: str | Path, *, topic: str | None = None
) -> tuple[list[str], NDArray[np.float64], NDArray[np.float64]]:
    """``(joint names, times (s), positions (T, n))`` of a ``JointState`` topic (rad or m)."""
    with _reader(path) as reader:
        conns = _connections(reader, ("sensor_msgs/msg/JointState",), topic, path)
        names: list[str] = []
        times, rows = [], []
        for conn, t, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            if not names:
                names = list(msg.name)
            if list(msg.name) != names:
                raise ConfigurationError(f"{path}: the joint names change along the bag")
            times.append(t * 1e-9)
            rows.append(np.asarray(msg.position, dtype=float))
    return names, np.asarray(times), np.asarray(rows).reshape(len(rows), len(names))
