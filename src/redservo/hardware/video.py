"""A :class:`~redservo.hardware.FeatureSource` that plays a video file as a camera at the
file's frame rate (``[camera] driver = "video"`` of ``redservo servo``): a rehearsal of the
vision side on recorded frames.

Frame ``i`` is due at ``t0 + i / fps`` on the loop's clock (``t0``: :meth:`VideoSource.start`)
and is stamped so; a worker thread waits for it, decodes it (OpenCV), converts it to gray
and measures it with :class:`~redservo.vision.frame_sensor.FrameSensor` (the dot tracker,
the tag detector), then hands the measurement over: :meth:`VideoSource.measure` never waits
for a frame. Frames whose time has passed while the tracker was busy are skipped (counted
in :attr:`VideoSource.skipped`), as a live camera's would be. At the end of the file no new
measurement comes: the servo loop ends ``stale_measurement`` after its watchdog timeout
(:attr:`VideoSource.ended` says why).

The camera (intrinsics, distortion) is the scenario's; the video must have its size.

Units: seconds, pixels.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.hardware.protocols import FeatureMeasurement
from redservo.scene import Scene
from redservo.task import VisualTask
from redservo.vision.frame_sensor import DOT_THRESHOLD, Frame, FrameSensor
from redservo.vision.optics import require_cv2

__all__ = ["VideoSource", "check_size"]


def _open(path: Path, camera: Camera, key: str) -> tuple[Any, float]:
    """The OpenCV capture of ``path`` and its frame rate (Hz), checked against ``camera``."""
    cv2 = require_cv2()
    if not path.is_file():
        raise ConfigurationError(f"{key}: no video file {path}", argument=key)
    cap = cv2.VideoCapture(str(path))
    fps = float(cap.get(cv2.CAP_PROP_FPS)) if cap.isOpened() else 0.0
    if not cap.isOpened():
        raise ConfigurationError(f"{key}: OpenCV cannot read the video {path}", argument=key)
    if not (math.isfinite(fps) and fps > 0.0):
        cap.release()
        raise ConfigurationError(f"{key}: the video {path} has no frame rate", argument=key)
    return check_size(cap, camera, f"the video {path}", key), fps


def check_size(cap: Any, camera: Camera, what: str, key: str) -> Any:
    """``cap`` (an OpenCV capture) when it delivers frames of the camera's size; else it is
    released and refused (naming ``key``)."""
    cv2 = require_cv2()
    size = (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)))
    if size != (camera.width, camera.height):
        cap.release()
        raise ConfigurationError(
            f"{key}: {what} delivers {size[0]} x {size[1]} pixels; the scenario's camera is "
            f"{camera.width} x {camera.height}",
            argument=key,
        )
    return cap


class VideoSource:
    """The task's features in a video file played at its rate (module docstring).

    Args:
        path: The video file (any format OpenCV reads).
        camera: The camera that filmed it (the scenario's).
        task, scene: The scenario's task and scene.
        pose: Gives the camera pose ``bMc`` for the first frame (``true_pose()``).
        dot_threshold: Gray level of the dots' ink (0-255).
        clock, sleep: The loop's monotonic clock and a sleep (s): injectable.
        key: The name of ``path`` in messages (the hardware file's key).

    Raises:
        ConfigurationError: the file is missing or unreadable, has no frame rate, or is not
            of the camera's size (naming ``key``).
    """

    def __init__(
        self,
        path: str | Path,
        camera: Camera,
        task: VisualTask,
        scene: Scene,
        pose: Any,
        *,
        dot_threshold: float = DOT_THRESHOLD,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        key: str = "camera.file",
    ) -> None:
        self.path = Path(path)
        self.key = key
        self._cap, self.fps = _open(self.path, camera, key)
        self._setup(camera, task, scene, pose, dot_threshold, clock, sleep)

    def _setup(
        self,
        camera: Camera,
        task: VisualTask,
        scene: Scene,
        pose: Any,
        dot_threshold: float,
        clock: Callable[[], float],
        sleep: Callable[[float], None],
    ) -> None:
        """The measuring and the worker's state, shared with the live camera
        (:class:`~redservo.hardware.device.DeviceSource`)."""
        self.task, self.scene, self.pose = task, scene, pose
        self.sensor = FrameSensor(camera, dot_threshold)
        self.clock, self.sleep = clock, sleep
        self._lock = threading.Lock()
        self._last: FeatureMeasurement | None = None
        self._error: BaseException | None = None
        self.frames = 0
        """Frames measured."""
        self.skipped = 0
        """Frames not measured: their time had passed while the tracker was busy."""
        self.ended = False
        """True once the source has no more frames."""
        self.reason = ""
        """Why the last frame gave no measurement ("" otherwise)."""
        self._closing = False
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start playing: frame 0 is due now (called by the first :meth:`measure`)."""
        if self._thread is None:
            t0 = self.clock()
            self._thread = threading.Thread(
                target=self._play, args=(t0,), name="redservo-video", daemon=True
            )
            self._thread.start()

    @property
    def threads(self) -> list[int]:
        """Native ids of the source's threads (the player), for their scheduling."""
        t = self._thread
        return [t.native_id] if t is not None and t.native_id and t.is_alive() else []

    def _play(self, t0: float) -> None:
        """The worker: :meth:`_deliver` the frames; what it raises is handed to the loop's
        thread by :meth:`measure`."""
        try:
            self._deliver(t0)
        except BaseException as exc:
            with self._lock:
                self._error = exc
        finally:
            self.ended = True

    def _deliver(self, t0: float) -> None:
        """Measure frame ``i`` at ``t0 + i / fps``, skipping the frames already late."""
        cv2 = require_cv2()
        i = 0
        while not self._closing:
            due = t0 + i / self.fps
            if self.clock() > due + 1.0 / self.fps:  # late: drop it as a camera would
                if not self._cap.grab():
                    break
                self.skipped, i = self.skipped + 1, i + 1
                continue
            ok, image = self._cap.read()
            if not ok:
                break
            if (wait := due - self.clock()) > 0:
                self.sleep(wait)
            self._measure(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), due)
            i += 1

    def _measure(self, gray: Any, stamp: float) -> None:
        assert isinstance(self.sensor.renderer, Frame)
        self.sensor.renderer.frame = gray
        reading = self.sensor.read(self.task, self.scene, self.pose.true_pose(), 0.0)
        self.reason = reading.reason
        with self._lock:
            self.frames += 1
            if reading.s is not None:
                self._last = FeatureMeasurement(
                    reading.s, tuple(reading.inv_depth), stamp, reading.no_pose
                )

    def measure(self, t: float) -> FeatureMeasurement | None:
        """The latest measurement (None before the first); never waits for a frame.

        Raises:
            Exception: what decoding or measuring a frame raised (playing has stopped).
        """
        self.start()
        with self._lock:
            if self._error is not None:
                raise self._error
            return self._last

    def first_measurement(self, timeout: float) -> FeatureMeasurement:
        """Start playing and wait up to ``timeout`` (s, on ``clock``) for a measurement.

        Raises:
            ConfigurationError: the target is not found in the first frame, or no frame was
                measured in time (naming the file).
        """
        deadline = self.clock() + timeout
        self.start()
        while True:
            with self._lock:
                if self._error is not None:
                    raise self._error
                last, frames = self._last, self.frames
            if last is not None:
                return last
            if frames or self.ended or self.clock() > deadline:
                why = self.reason or "no frame measured in time"
                raise ConfigurationError(
                    f"{self.key}: the target is not found in the first frame of {self.path}: "
                    f"{why}; nothing was sent",
                    argument=self.key,
                )
            self.sleep(0.005)

    def close(self) -> None:
        """Stop playing and release the file (safe to call twice)."""
        self._closing = True
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        self._cap.release()
