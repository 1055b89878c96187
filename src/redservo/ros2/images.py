"""``sensor_msgs/msg/Image`` and ``CameraInfo`` to and from redservo's images and cameras.

* :func:`gray_image`: an ``Image`` of encoding ``mono8``, ``rgb8``, ``bgr8``, ``rgba8``,
  ``bgra8``, ``mono16`` or ``16UC1`` as a gray (H, W) ``uint8`` array (the conversion of
  :mod:`redservo.vision.bags`, shared with ROS bags); an unknown encoding or data shorter
  than ``height x step`` is a :class:`~redservo.ros2.faults.MessageError` naming the topic;
* :func:`camera_from_info`: the intrinsics and distortion (``plumb_bob``,
  ``rational_polynomial``'s first five) of a ``CameraInfo`` as a
  :class:`~redservo.camera.Camera` (ROS puts pixel centres on the integers, redservo on the
  half-integers: ``u0 = cx + 0.5``);
* :func:`rgb_message`, :func:`info_message`: the other way, for the rehearsal arm.

Units: pixels.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from redservo.camera import Camera
from redservo.errors import RedservoError
from redservo.ros2.faults import MessageError
from redservo.ros2.messages import CameraInfo, Header, Image

__all__ = ["camera_from_info", "gray_image", "info_message", "rgb_message"]

DISTORTION_MODELS = ("plumb_bob", "rational_polynomial", "")
"""``CameraInfo.distortion_model`` values read: their first five ``d`` are OpenCV's."""


def gray_image(msg: Image, topic: str) -> NDArray[np.uint8]:
    """The gray (H, W) uint8 image of ``msg`` (module docstring).

    Raises:
        MessageError: an unknown encoding or a wrong size (names ``topic``).
    """
    from redservo.vision.bags import _gray

    try:
        return _gray(msg, "sensor_msgs/msg/Image")
    except RedservoError as exc:
        raise MessageError(f"Image on {topic}: {exc}", argument=topic) from None


def camera_from_info(msg: CameraInfo, topic: str) -> Camera:
    """The camera of a ``CameraInfo`` (module docstring).

    Raises:
        MessageError: an unknown distortion model or an invalid camera (names ``topic``).
    """
    from redservo.vision.bags import _camera

    if msg.distortion_model not in DISTORTION_MODELS:
        raise MessageError(
            f"CameraInfo on {topic}: distortion model {msg.distortion_model!r} is not read; "
            f"allowed: {', '.join(repr(m) for m in DISTORTION_MODELS)}",
            argument=topic,
        )
    try:
        return _camera(msg)
    except RedservoError as exc:
        raise MessageError(
            f"CameraInfo on {topic}: not a valid camera ({exc})", argument=topic
        ) from None


def rgb_message(rgb: NDArray[np.uint8], header: Header) -> Image:
    """An ``rgb8`` ``Image`` of an (H, W, 3) uint8 array."""
    h, w = int(rgb.shape[0]), int(rgb.shape[1])
    data = np.ascontiguousarray(rgb, dtype=np.uint8).tobytes()
    return Image(header, h, w, "rgb8", 0, 3 * w, data)


def info_message(camera: Camera, header: Header) -> CameraInfo:
    """The ``CameraInfo`` of ``camera`` (``plumb_bob``; identity rectification)."""
    cx, cy = camera.u0 - 0.5, camera.v0 - 0.5
    k = [camera.px, 0.0, cx, 0.0, camera.py, cy, 0.0, 0.0, 1.0]
    p = [camera.px, 0.0, cx, 0.0, 0.0, camera.py, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    return CameraInfo(
        header,
        camera.height,
        camera.width,
        "plumb_bob",
        [float(v) for v in camera.distortion],
        k,
        r,
        p,
    )
