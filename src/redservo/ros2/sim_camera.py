"""The rehearsal arm's camera: the arm's view rendered by MuJoCo and published as a ROS 2
camera driver does (``Image`` ``rgb8`` on ``image``, ``CameraInfo`` on ``camera_info``,
both best effort, the same stamp: the time of the joint positions rendered).

Rendering runs in its own thread on its own copy of the arm (its own MuJoCo data), so the
physics keeps its real-time step while a frame renders (tens of ms in software OpenGL).

Units: seconds, Hz.
"""

from __future__ import annotations

import math
import threading
import time

import numpy as np

from redservo.errors import ConfigurationError
from redservo.experiment.build import Experiment
from redservo.ros2.images import info_message, rgb_message
from redservo.ros2.messages import CameraInfo, Header, Image
from redservo.ros2.naming import validate_topic
from redservo.ros2.stamps import EpochStamps
from redservo.ros2.transport import SENSOR_DATA, Ros2Node

__all__ = ["SimCamera"]


class SimCamera:
    """Publish the rendered view of the arm at ``rate`` Hz (module docstring).

    Args:
        exp: The scenario (robot, scene, camera).
        node: The DDS participant.
        stamps: The arm's epoch conversion (same stamps as its joint states).
        image: Image topic.
        camera_info: CameraInfo topic.
        rate: Frames per second, in (0, 60].

    Raises:
        ConfigurationError: a bad rate or topic.
    """

    def __init__(
        self,
        exp: Experiment,
        node: Ros2Node,
        stamps: EpochStamps,
        *,
        image: str = "/camera/image_raw",
        camera_info: str = "/camera/camera_info",
        rate: float = 10.0,
    ) -> None:
        from redservo.physics.arm import MujocoArm

        if not (math.isfinite(rate) and 0.0 < rate <= 60.0):
            raise ConfigurationError(
                f"image rate must be in (0, 60] Hz, got {rate!r}", argument="image_rate"
            )
        self.exp, self.stamps, self.period = exp, stamps, 1.0 / rate
        self.view = MujocoArm(exp.robot, exp.scene, camera=exp.camera, q_ref=exp.q0)
        self._image = node.writer(validate_topic(image, "image"), Image, SENSOR_DATA)
        self._info = node.writer(
            validate_topic(camera_info, "camera_info"), CameraInfo, SENSOR_DATA
        )
        self._lock = threading.Lock()
        self._state: tuple[np.ndarray, float, float] | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.frames = 0

    def update(self, q: np.ndarray, t_mono: float, t_scene: float) -> None:
        """The arm's newest state: joints ``q``, its time (loop clock) and scene time (s)."""
        with self._lock:
            self._state = (np.array(q), t_mono, t_scene)

    def _serve(self) -> None:
        try:
            self._frames()
        finally:
            self.view.close()  # in the thread that made the OpenGL context

    def _frames(self) -> None:
        next_frame = time.monotonic()
        while not self._stop.wait(max(next_frame - time.monotonic(), 0.0)):
            next_frame = max(next_frame + self.period, time.monotonic())
            with self._lock:
                state = self._state
            if state is None:
                continue
            q, t_mono, t_scene = state
            self.view.set_q(q)
            rgb = self.view.render(t_scene)
            header = Header(self.stamps.to_ros(t_mono), "camera")
            self._info.write(info_message(self.exp.camera, header))
            self._image.write(rgb_message(rgb, header))
            self.frames += 1

    def start(self) -> None:
        """Start publishing (a daemon thread)."""
        self._thread = threading.Thread(target=self._serve, name="sim-camera", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop publishing and free the renderer."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
