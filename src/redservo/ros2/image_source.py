"""A :class:`~redservo.hardware.FeatureSource` over a ROS 2 camera: ``Image`` + ``CameraInfo``.

The intrinsics and distortion come from ``CameraInfo`` (:func:`wait_for_camera`); each new
``Image`` (any encoding of :func:`~redservo.ros2.images.gray_image`) goes through the image
sensor of :mod:`redservo.vision.sensor` (our dot tracker; tags with the tag detector) with
the task and the scene of the scenario; the camera pose it needs for its first frame (where
to look for the dots) is the model's at the measured joints. A dot target is dark ink on a
light surface, found below ``dot_threshold`` gray levels (55: the rehearsal arm's rendered
ink, :data:`redservo.physics.camera.DOT_THRESHOLD`).

Decoding and detection run on a worker thread (:mod:`redservo.ros2.tracking`), so a slow
frame never delays the control loop; the measurement is stamped with the image's stamp on
the loop's clock (``EpochStamps``); until a newer image is measured, :meth:`Ros2ImageSource.
measure` returns the previous measurement (same stamp: "no new image yet"). An image of an
unknown encoding or of another size than ``CameraInfo`` says is a
:class:`~redservo.ros2.faults.MessageError` naming the topic (the loop stops the arm).

Units: seconds, pixels, normalized image coordinates.
"""

from __future__ import annotations

import time
from typing import Any

from redservo.camera import Camera
from redservo.hardware.protocols import FeatureMeasurement
from redservo.ros2.faults import MessageError
from redservo.ros2.images import camera_from_info, gray_image
from redservo.ros2.messages import CameraInfo, Image
from redservo.ros2.naming import validate_topic
from redservo.ros2.stamps import EpochStamps
from redservo.ros2.tracking import FrameWorker
from redservo.ros2.transport import SENSOR_DATA, Ros2Node
from redservo.scene import Scene
from redservo.task import VisualTask
from redservo.vision.frame_sensor import DOT_THRESHOLD, Frame, FrameSensor

__all__ = ["DOT_THRESHOLD", "FrameSensor", "Ros2ImageSource", "wait_for_camera"]


def wait_for_camera(node: Ros2Node, topic: str, timeout: float) -> Camera:
    """The camera of the first ``CameraInfo`` on ``topic`` within ``timeout`` (s).

    Raises:
        MessageError: none arrived, or it is not a valid camera (names the topic).
    """
    reader = node.reader(validate_topic(topic, "camera.camera_info"), CameraInfo, SENSOR_DATA)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for msg in reader.take(N=16):
            if isinstance(msg, CameraInfo):
                return camera_from_info(msg, topic)
        time.sleep(0.01)
    raise MessageError(f"no CameraInfo on {topic} within {timeout:g} s", argument=topic)


class Ros2ImageSource:
    """The task's features in the newest ``Image`` of ``topic`` (module docstring).

    Decoding and detection run on a worker thread (:class:`~redservo.ros2.tracking.
    FrameWorker`); :meth:`measure` returns its latest measurement without waiting.

    Args:
        node: The DDS participant.
        topic: The ``Image`` topic.
        camera: The camera (:func:`wait_for_camera`); images must have its size.
        task, scene: The scenario's task and scene.
        pose: Gives the camera pose ``bMc`` at the measured joints (``true_pose()``), called
            on the worker's thread.
        stamps: Epoch to loop clock.
        dot_threshold: Gray level of the ink (0-255).
    """

    def __init__(
        self,
        node: Ros2Node,
        topic: str,
        camera: Camera,
        task: VisualTask,
        scene: Scene,
        pose: Any,
        stamps: EpochStamps,
        dot_threshold: float = DOT_THRESHOLD,
    ) -> None:
        self.topic = validate_topic(topic, "camera.image")
        self.camera, self.task, self.scene, self.pose = camera, task, scene, pose
        self.stamps = stamps
        self.sensor = FrameSensor(camera, dot_threshold)
        self.reason = ""
        """Why the last frame gave no measurement ("" otherwise)."""
        reader = node.reader(self.topic, Image, SENSOR_DATA)
        self.worker: FrameWorker[FeatureMeasurement] = FrameWorker(
            node._open(), reader, Image, self._track, name=f"redservo-tracking {self.topic}"
        )

    @property
    def frames(self) -> int:
        """Images measured so far."""
        return self.worker.frames

    @property
    def skipped(self) -> int:
        """Images not measured because a newer one had arrived (the tracker was busy)."""
        return self.worker.skipped

    @property
    def threads(self) -> list[int]:
        """Native ids of the source's threads (the tracker), for their scheduling."""
        tid = self.worker.native_id
        return [] if tid is None or not self.worker.alive else [tid]

    def first_measurement(self, timeout: float) -> FeatureMeasurement:
        """Wait up to ``timeout`` (s) for an image and measure it (before the first command).

        Raises:
            MessageError: no image arrived, or the target is not found in it (names the
                topic and says why).
        """
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            meas = self.measure(time.monotonic())
            if meas is not None:
                return meas
            if self.frames:
                raise MessageError(
                    f"the target is not found in the first image on {self.topic}: "
                    f"{self.reason}; nothing was sent",
                    argument=self.topic,
                )
            time.sleep(0.01)
        raise MessageError(f"no Image on {self.topic} within {timeout:g} s", argument=self.topic)

    def _track(self, msg: Image) -> FeatureMeasurement | None:
        """Decode and measure one image (on the worker's thread), stamped with its stamp."""
        gray = gray_image(msg, self.topic)
        if gray.shape != (self.camera.height, self.camera.width):
            raise MessageError(
                f"Image on {self.topic} is {gray.shape[1]} x {gray.shape[0]} pixels; its "
                f"CameraInfo says {self.camera.width} x {self.camera.height}",
                argument=self.topic,
            )
        assert isinstance(self.sensor.renderer, Frame)
        self.sensor.renderer.frame = gray
        reading = self.sensor.read(self.task, self.scene, self.pose.true_pose(), 0.0)
        self.reason = reading.reason
        if reading.s is None:
            return None
        stamp = self.stamps.to_loop(msg.header.stamp)
        return FeatureMeasurement(reading.s, tuple(reading.inv_depth), stamp)

    def measure(self, t: float) -> FeatureMeasurement | None:
        """The latest measurement (the same one again until a newer image is measured).

        Raises:
            MessageError: the tracker met an unusable image (it has stopped).
        """
        return self.worker.latest()

    def close(self) -> None:
        """Stop the tracker (safe to call twice)."""
        self.worker.close()
