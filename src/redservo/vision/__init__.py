"""Image in the loop: render the camera image, detect the features in it (extra ``redservo[vision]``).

Importing this package does not import OpenCV; every public name is loaded on
first use (``from redservo.vision import ImageSensor``). A missing OpenCV raises
:class:`~redservo.errors.ConfigurationError` saying ``pip install 'redservo[vision]'``
when a function needs it.

* :mod:`~redservo.vision.render` — :class:`RenderOptions`, :class:`Renderer` (and ``render.render`` for one frame)
* :mod:`~redservo.vision.dots` — :func:`detect_dots`, :class:`DotTracker`
* :mod:`~redservo.vision.tracking` — :class:`ImageDotTracker` (gray levels, re-acquisition, loss reasons)
* :mod:`~redservo.vision.ellipse` — :func:`detect_ellipse`
* :mod:`~redservo.vision.lines` — :func:`refine_line`, :func:`find_lines`, :func:`orient_like`
* :mod:`~redservo.vision.moments` — :func:`dot_moment_features`, :func:`region_moments`
* :mod:`~redservo.vision.depth` — the depth policies, :func:`estimate_inv_depth`
* :mod:`~redservo.vision.sensor` — :class:`ImageSensor` (a :class:`redservo.sensors.Sensor`)
* :mod:`~redservo.vision.sources` — :func:`frames`, :func:`numbered_frames`, :func:`track_dots`
  (video, folder, webcam; a damaged or truncated video is a :class:`VideoWarning`,
  :mod:`~redservo.vision.capture`)
* :mod:`~redservo.vision.video` — :func:`write_video` (GIF / MP4 with overlays)
* :mod:`~redservo.vision.optics` — :class:`Optics` (intrinsics + radial distortion)
* :mod:`~redservo.vision.tags` — :func:`detect_tags`, :class:`TagDetection`, :func:`iter_tags` (AprilTag, ArUco)
* :mod:`~redservo.vision.tag_source` — :class:`TagFeatureSource` (tags in real frames, for the servo loop)

See docs/vision.md.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "DEPTH_POLICIES",
    "FEATURE_LOST",
    "DotTracker",
    "ImageDotTracker",
    "ImageSensor",
    "Optics",
    "RenderOptions",
    "Renderer",
    "TagDetection",
    "TagFeatureSource",
    "VideoWarning",
    "detect_dots",
    "detect_ellipse",
    "detect_tags",
    "dot_moment_features",
    "estimate_inv_depth",
    "find_lines",
    "frames",
    "iter_tags",
    "numbered_frames",
    "orient_like",
    "refine_line",
    "region_moments",
    "track_dots",
    "write_video",
]

_WHERE = {
    "DEPTH_POLICIES": "depth",
    "estimate_inv_depth": "depth",
    "FEATURE_LOST": "sensor",
    "ImageSensor": "sensor",
    "DotTracker": "dots",
    "ImageDotTracker": "tracking",
    "detect_dots": "dots",
    "detect_ellipse": "ellipse",
    "find_lines": "lines",
    "orient_like": "lines",
    "refine_line": "lines",
    "dot_moment_features": "moments",
    "region_moments": "moments",
    "Optics": "optics",
    "RenderOptions": "render",
    "Renderer": "render",
    "frames": "sources",
    "numbered_frames": "sources",
    "VideoWarning": "capture",
    "track_dots": "sources",
    "write_video": "video",
    "TagDetection": "tags",
    "TagFeatureSource": "tag_source",
    "detect_tags": "tags",
    "iter_tags": "tags",
}


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'redservo.vision' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"redservo.vision.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
