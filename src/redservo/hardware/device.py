"""A :class:`~redservo.hardware.FeatureSource` on a live camera device read through OpenCV
(``[camera] driver = "device"`` of ``redservo servo``): a USB or built-in camera without ROS.

A worker thread reads the frames as the device delivers them (``cv2.VideoCapture(device)``,
asked for the scenario camera's size), converts each to gray and measures it with
:class:`~redservo.vision.frame_sensor.FrameSensor` (the dot tracker, the tag detector), then
hands the measurement over: :meth:`DeviceSource.measure` never waits for a frame. A frame is
stamped with the loop's clock when the read returned, less the camera's ``latency`` (s, from
the middle of the exposure to the frame's delivery: OpenCV gives no exposure time, so the
user states it; 0 when unknown, and the servo loop's watchdog still bounds the staleness).
When the device stops delivering, no new measurement comes and the servo loop ends
``stale_measurement`` after its watchdog timeout.

The camera's intrinsics and distortion are the scenario's; the device must deliver frames of
its size.

Units: seconds, pixels.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.hardware.video import VideoSource, check_size
from redservo.scene import Scene
from redservo.task import VisualTask
from redservo.vision.frame_sensor import DOT_THRESHOLD
from redservo.vision.optics import require_cv2

__all__ = ["DeviceSource", "check_size", "open_device"]


def open_device(device: int | str, camera: Camera, key: str = "camera.device") -> Any:
    """The OpenCV capture of ``device`` (an index or a path such as ``/dev/video0``), asked
    for the camera's size and checked to deliver it.

    Raises:
        ConfigurationError: the device cannot be opened or delivers another size (naming
            ``key``).
    """
    cv2 = require_cv2()
    cap = cv2.VideoCapture(device)
    if not cap.isOpened():
        raise ConfigurationError(f"{key}: OpenCV cannot open the camera {device!r}", argument=key)
    cap.set(cv2.CAP_PROP_FRAME_WIDTH, camera.width)
    cap.set(cv2.CAP_PROP_FRAME_HEIGHT, camera.height)
    return check_size(cap, camera, f"the camera {device!r}", key)


class DeviceSource(VideoSource):
    """The task's features on a live camera (module docstring).

    Args:
        capture: An opened OpenCV capture (:func:`open_device`), or any object with its
            ``read()``, ``get()`` and ``release()``.
        camera: The camera's model (the scenario's).
        task, scene: The scenario's task and scene.
        pose: Gives the camera pose ``bMc`` (``true_pose()``).
        latency: The camera's latency (s, >= 0): mid-exposure to delivery.
        dot_threshold: Gray level of the dots' ink (0-255).
        clock, sleep: The loop's monotonic clock and a sleep (s): injectable.
        name: What the messages call the device.

    Raises:
        ConfigurationError: ``latency`` is not a finite number >= 0.
    """

    def __init__(
        self,
        capture: Any,
        camera: Camera,
        task: VisualTask,
        scene: Scene,
        pose: Any,
        *,
        latency: float = 0.0,
        dot_threshold: float = DOT_THRESHOLD,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        name: str = "the camera",
    ) -> None:
        if isinstance(latency, bool) or not (
            isinstance(latency, int | float) and math.isfinite(latency) and latency >= 0.0
        ):
            raise ConfigurationError(
                f"camera.latency must be a number >= 0 (s), got {latency!r}",
                argument="camera.latency",
            )
        self.path = name  # type: ignore[assignment]  # what the messages name
        self.key = "camera.device"
        self._cap, self.fps = capture, math.nan
        self.latency = float(latency)
        self._setup(camera, task, scene, pose, dot_threshold, clock, sleep)

    def _deliver(self, t0: float) -> None:
        """Measure every frame as the device delivers it (the newest wins)."""
        cv2 = require_cv2()
        while not self._closing:
            ok, image = self._cap.read()
            if not ok:
                break
            stamp = self.clock() - self.latency
            gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
            self._measure(gray, stamp)
