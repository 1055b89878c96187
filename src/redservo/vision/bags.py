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

A damaged or truncated bag (an unreadable index, a malformed database, a message that does
not deserialize) and a bad image message (data shorter than ``height × step``, a ``step``
shorter than a row, a zero or over-cap size, an undecodable compressed image) raise one
:class:`~redservo.errors.ConfigurationError` naming the bag and, where known, the topic and
the message's index on it (0-based): ``run.bag: topic /camera/image_raw, message 4: ...``.
Whatever exception ``rosbags`` (or its SQLite, MCAP or compression back ends) raises on a
damaged file is reported that way; nothing is skipped.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo.camera import Camera
from redservo.errors import ConfigurationError, RedservoError
from redservo.vision.imagefile import check_frame_size
from redservo.vision.optics import require_cv2

__all__ = ["bag_camera", "bag_frames", "bag_joint_states", "is_bag"]

_IMAGE = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")


def is_bag(source: Any) -> bool:
    """Whether ``source`` names a ROS 1 bag file or a ROS 2 bag folder."""
    if not isinstance(source, str | Path):
        return False
    p = Path(source)
    return (p.is_file() and p.suffix == ".bag") or (p.is_dir() and (p / "metadata.yaml").is_file())


def _damaged(path: Any, exc: BaseException, where: str = "") -> ConfigurationError:
    detail = " ".join(str(exc).split())[:300] or "no detail"
    what = where or "not a readable ROS bag: "
    return ConfigurationError(
        f"{path}: {what}damaged or truncated ({type(exc).__name__}: {detail})",
        argument="source",
    )


@contextmanager
def _open(path: str | Path) -> Iterator[Any]:
    """The opened ``rosbags`` reader of ``path``; a damaged bag is a ConfigurationError."""
    try:
        from rosbags.highlevel import AnyReader
    except ImportError as exc:  # pragma: no cover - the extra is installed in CI
        raise ConfigurationError(
            f"reading a ROS bag needs rosbags: pip install 'redservo[bags]' ({exc})"
        ) from None
    try:
        reader = AnyReader([Path(path)])
        reader.open()
    except Exception as exc:  # rosbags, SQLite, MCAP, YAML: whatever a damaged file raises
        raise _damaged(path, exc) from None
    try:
        yield reader
    finally:
        with suppress(Exception):  # closing a damaged bag; the first error is reported
            reader.close()


def _messages(reader: Any, conns: list[Any], path: Any) -> Iterator[tuple[int, Any, int, Any]]:
    """``(index on the topic, connection, time (ns), message)`` in time order; a message that
    cannot be read or deserialized is a ConfigurationError naming the topic and index."""
    it = reader.messages(connections=conns)
    topic = conns[0].topic
    k = 0
    while True:
        try:
            item = next(it, None)
        except Exception as exc:
            raise _damaged(path, exc, f"topic {topic}, message {k}: ") from None
        if item is None:
            return
        conn, t, raw = item
        try:
            msg = reader.deserialize(raw, conn.msgtype)
        except Exception as exc:
            raise _damaged(path, exc, f"topic {topic}, message {k} ({conn.msgtype}): ") from None
        yield k, conn, t, msg
        k += 1


def _connections(reader: Any, types: tuple[str, ...], topic: str | None, path: Any) -> list[Any]:
    conns = [c for c in reader.connections if c.msgtype in types]
    if topic is not None:
        conns = [c for c in conns if c.topic == topic]
    if not conns:
        have = ", ".join(sorted(f"{c.topic} ({c.msgtype})" for c in reader.connections)) or "none"
        what = f"topic {topic!r} of type" if topic else "a topic of type"
        raise ConfigurationError(f"{path}: no {what} {' or '.join(types)}; its topics: {have}")
    return [c for c in conns if c.topic == conns[0].topic]


_CHANNELS = {"mono8": 1, "8uc1": 1, "bgr8": 3, "rgb8": 3, "bgra8": 4, "rgba8": 4}
_TO_GRAY = {"bgr8": "COLOR_BGR2GRAY", "rgb8": "COLOR_RGB2GRAY", "bgra8": "COLOR_BGRA2GRAY"}


def _compressed(msg: Any) -> NDArray[np.uint8]:
    cv2 = require_cv2()
    img = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise ConfigurationError(f"cannot decode the compressed image ({msg.format!r})")
    return np.asarray(img, dtype=np.uint8)


def _raw_layout(msg: Any) -> tuple[str, int, int, int, int]:
    """``(encoding, height, width, step, bytes per pixel)`` of an Image, checked against its data."""
    enc = str(msg.encoding).lower()
    if enc not in (*_CHANNELS, "mono16", "16uc1"):
        raise ConfigurationError(
            f"image encoding {msg.encoding!r} is not supported; allowed: "
            f"{', '.join([*_CHANNELS, 'mono16', '16uc1'])}"
        )
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    pixel = 2 if enc in ("mono16", "16uc1") else _CHANNELS[enc]
    if h < 1 or w < 1:
        raise ConfigurationError(f"an image of {w} x {h} pixels; both must be at least 1")
    check_frame_size(w, h, "the image message")
    if step < w * pixel:
        raise ConfigurationError(f"step {step} bytes is shorter than a row ({w} x {pixel} bytes)")
    if len(msg.data) < h * step:
        raise ConfigurationError(
            f"{len(msg.data)} bytes of data, fewer than height x step = {h} x {step}"
        )
    return enc, h, w, step, pixel


def _gray(msg: Any, msgtype: str) -> NDArray[np.uint8]:
    """The grayscale image of an Image or CompressedImage message (ConfigurationError if bad)."""
    if msgtype.endswith("CompressedImage"):
        return _compressed(msg)
    enc, h, w, step, pixel = _raw_layout(msg)
    data = np.frombuffer(bytes(msg.data), np.uint8)[: h * step]
    if enc in ("mono16", "16uc1"):
        dt = np.dtype(">u2" if msg.is_bigendian else "<u2")
        img16 = data[: h * (step // 2) * 2].view(dt).reshape(h, step // 2)[:, :w]
        return np.asarray(img16 >> 8, dtype=np.uint8)
    img = data.reshape(h, step)[:, : w * pixel].reshape(h, w, pixel)
    if pixel == 1:
        return np.ascontiguousarray(img[..., 0])
    cv2 = require_cv2()
    code = getattr(cv2, _TO_GRAY.get(enc, "COLOR_RGBA2GRAY"))
    return np.asarray(cv2.cvtColor(np.ascontiguousarray(img), code), dtype=np.uint8)


def bag_frames(
    path: str | Path, *, topic: str | None = None, max_frames: int | None = None
) -> Iterator[NDArray[np.uint8]]:
    """The grayscale frames (H, W) uint8 of an image topic, in time order.

    Raises:
        ConfigurationError: no such topic, a damaged bag or a bad image message (the message
            names the bag, the topic and the message's index).
    """
    with _open(path) as reader:
        conns = _connections(reader, _IMAGE, topic, path)
        for k, conn, _, msg in _messages(reader, conns, path):
            if max_frames is not None and k >= max_frames:
                break
            try:
                img = _gray(msg, conn.msgtype)
            except ConfigurationError as exc:
                raise ConfigurationError(
                    f"{path}: topic {conn.topic}, message {k}: {exc}", argument="source"
                ) from None
            yield img


def _camera(msg: Any) -> Camera:
    K = np.asarray(msg.k if hasattr(msg, "k") else msg.K, dtype=float).ravel()
    if K.shape != (9,):
        raise ConfigurationError(f"K holds {K.size} numbers, expected 9")
    D = list(np.asarray(msg.d if hasattr(msg, "d") else msg.D, dtype=float)) + [0.0] * 5
    k1, k2, p1, p2, k3 = D[:5]
    # ROS puts pixel centres on the integers (as OpenCV); redservo on the half-integers
    px, py, u0, v0 = float(K[0]), float(K[4]), float(K[2]) + 0.5, float(K[5]) + 0.5
    w, h = int(msg.width), int(msg.height)
    return Camera(px, py, u0, v0, w, h, k1=k1, k2=k2, p1=p1, p2=p2, k3=k3)


def bag_camera(path: str | Path, *, topic: str | None = None) -> Camera:
    """The camera of the first ``CameraInfo`` message: intrinsics, size, distortion.

    Raises:
        ConfigurationError: no CameraInfo topic or message, a damaged bag, or a CameraInfo
            that is not a valid camera (names the bag, topic and message).
    """
    with _open(path) as reader:
        conns = _connections(reader, ("sensor_msgs/msg/CameraInfo",), topic, path)
        for k, conn, _, msg in _messages(reader, conns, path):
            try:
                return _camera(msg)
            except RedservoError as exc:
                raise ConfigurationError(
                    f"{path}: topic {conn.topic}, message {k}: not a valid camera ({exc})",
                    argument="source",
                ) from None
    raise ConfigurationError(f"{path}: the CameraInfo topic has no message")


def bag_joint_states(
    path: str | Path, *, topic: str | None = None
) -> tuple[list[str], NDArray[np.float64], NDArray[np.float64]]:
    """``(joint names, times (s), positions (T, n))`` of a ``JointState`` topic (rad or m).

    Raises:
        ConfigurationError: no JointState topic, a damaged bag, joint names that change, or
            a message whose positions do not match its names (names the bag, topic, message).
    """
    with _open(path) as reader:
        conns = _connections(reader, ("sensor_msgs/msg/JointState",), topic, path)
        names: list[str] = []
        times, rows = [], []
        for k, conn, t, msg in _messages(reader, conns, path):
            if not names:
                names = list(msg.name)
            where = f"{path}: topic {conn.topic}, message {k}"
            if list(msg.name) != names:
                raise ConfigurationError(f"{where}: the joint names change along the bag")
            q = np.asarray(msg.position, dtype=float)
            if q.shape != (len(names),):
                raise ConfigurationError(
                    f"{where}: {q.size} positions for {len(names)} joint names"
                )
            times.append(t * 1e-9)
            rows.append(q)
    return names, np.asarray(times), np.asarray(rows).reshape(len(rows), len(names))
