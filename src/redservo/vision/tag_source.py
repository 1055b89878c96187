"""Real input to the servo loop: a :class:`~redservo.hardware.FeatureSource` of tag features.

:class:`TagFeatureSource` reads the frames of any source :func:`~redservo.vision.sources.frames`
takes (a camera index, a video, an image folder, a ROS bag, a list of images), detects the
task's tags in each with :func:`~redservo.vision.detect_tags` and returns the task's features
the way the image sensor measures them on rendered images (:mod:`redservo.vision.tag_sensor`):
a tag corner's point feature, or a pose feature of the tag's detected pose, with the inverse
depths from that pose. Every term must observe a tag (``tags[target]``).

Each :meth:`~TagFeatureSource.measure` call takes the next frame, stamped with the loop time
``t`` it was read at (the sources here carry no clock; a driver with camera stamps converts them
to the loop's clock itself). A frame in which a term's tag is not found, or the end of the
source, returns None (the loop's "target lost"); :attr:`TagFeatureSource.reason` says why. A
video frame that could not be decoded is such a frame too (its number kept,
:mod:`redservo.vision.capture`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.hardware.protocols import FeatureMeasurement
from redservo.scene import Tag
from redservo.vision.optics import Optics
from redservo.vision.sources import numbered_frames
from redservo.vision.tag_sensor import TagTerm, measure_tag, tag_term

if TYPE_CHECKING:  # pragma: no cover
    from redservo.task import VisualTask

__all__ = ["TagFeatureSource"]


class TagFeatureSource:
    """The task's tag features measured in the frames of ``source`` (module docstring).

    Args:
        task: The task (its terms give the features and their targets, in order).
        tags: The tag of each target name.
        source: Anything :func:`~redservo.vision.sources.frames` reads.
        camera: The camera's intrinsics and distortion (or an :class:`Optics`).

    Raises:
        ConfigurationError: a term's target is not in ``tags``, or a term is not a tag corner
            or a pose feature; when reading, a source that is not readable (a list holding
            something other than images or image file paths, a missing file, ...).
    """

    def __init__(
        self, task: VisualTask, tags: Mapping[str, Tag], source: Any, camera: Camera | Optics
    ) -> None:
        self.optics = camera if isinstance(camera, Optics) else Optics(camera)
        self.task = task
        self._terms: list[TagTerm] = []
        for i, term in enumerate(task.terms):
            tag = tags.get(term.target)
            if tag is None:
                raise ConfigurationError(
                    f"term {i}: no tag for target {term.target!r}; given: {sorted(tags)}"
                )
            st = tag_term(i, term.feature, tag)
            if st is None:
                raise ConfigurationError(
                    f"term {i}: {type(term.feature).__name__} is not measured on a tag (a "
                    "point feature on a corner or a pose feature)"
                )
            self._terms.append(st)
        self._frames: Iterator[tuple[int, NDArray[np.uint8]]] = numbered_frames(source)
        self._next: tuple[int, NDArray[np.uint8]] | None = None
        self.reason = ""
        """Why the last :meth:`measure` returned None ("" otherwise)."""
        self.frame = -1
        """Index of the last frame read (0-based)."""

    def measure(self, t: float) -> FeatureMeasurement | None:
        """The features in the next frame, stamped ``t`` (s), or None (see :attr:`reason`)."""
        if self._next is None:
            self._next = next(self._frames, None)
        if self._next is None:
            self.reason = "the source has no more frames"
            return None
        self.frame += 1
        if self._next[0] > self.frame:  # a video frame that could not be decoded
            self.reason = f"frame {self.frame}: damaged (could not be decoded)"
            return None
        image, self._next = self._next[1], None
        parts, depths = [], []
        for i, (term, st) in enumerate(zip(self.task.terms, self._terms)):
            s, why = measure_tag(image, self.optics, st, term.feature)
            if s is None or st.inv_depth is None:
                self.reason = f"frame {self.frame}, term {i}: {why or 'no depth'}"
                return None
            parts.append(s)
            depths.append(st.inv_depth)
        self.reason = ""
        return FeatureMeasurement(np.concatenate(parts), tuple(depths), float(t))
