"""The image sensor on frames it is given (a camera's, a video's) rather than rendered ones.

:class:`FrameSensor` runs the sensor of :mod:`redservo.vision.sensor` (our dot tracker; tags
with the tag detector) on the frame set in ``sensor.renderer.frame``; a dot target is dark
ink on a light surface, found below ``dot_threshold`` gray levels (55: the rehearsal arm's
rendered ink, :data:`redservo.physics.camera.DOT_THRESHOLD`).

Units: pixels, gray levels (0-255).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.scene import Scene
from redservo.vision.dots import detect_dots
from redservo.vision.render import Renderer
from redservo.vision.sensor import ImageSensor

__all__ = ["DOT_THRESHOLD", "Frame", "FrameSensor"]

DOT_THRESHOLD = 55.0
"""Gray level below which a pixel is ink (the rehearsal arm's: :mod:`redservo.physics.camera`)."""


class Frame(Renderer):
    """A renderer that returns the frame it was given (the newest camera image)."""

    frame: NDArray[np.uint8] | None = None

    def render(self, scene: Scene, bMc: FloatArray, t: float = 0.0) -> NDArray[np.uint8]:
        assert self.frame is not None
        return self.frame


class FrameSensor(ImageSensor):
    """The image sensor on given frames, dots as dark ink below ``dot_threshold``."""

    def __init__(self, camera: Camera, dot_threshold: float = DOT_THRESHOLD) -> None:
        super().__init__(camera)
        self.renderer = Frame(camera, self.renderer.options)
        self.dot_threshold = float(dot_threshold)

    def _read_dots(
        self, image: Any, scene: Scene, bMc: FloatArray, t: float, first: bool, notes: list[str]
    ) -> FloatArray:
        if self._tracker is None:
            return np.zeros((0, 2))
        det = detect_dots(
            image,
            threshold=self.dot_threshold,
            polarity="dark",
            min_size_px=2.0,
            max_size_px=0.25 * min(image.shape),
            pad_px=2.5,
        )
        if first:
            self._tracker.start(self._truth_uv(scene, bMc, t))
        track = self._tracker.update(det.uv)
        if track.n_blobs != self._tracker.n_dots:
            notes.append(f"found {track.n_blobs} dot blob(s), expected {self._tracker.n_dots}")
        self._detected = track.detected
        self.dots_uv = track.uv
        return self.renderer.optics.to_normalized(track.uv)
