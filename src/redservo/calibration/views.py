"""How good a set of calibration views is: duplicates, coverage of the image, tilt spread.

``cv2.calibrateCamera`` fits whatever it is given: six copies of one image give a small RMS
error and a meaningless distortion. Zhang's method needs *different* views of the plane,
tilted about different axes, and the distortion is only known where the pattern was seen.
So before and after the fit, :func:`redservo.calibration.calibrate_camera` checks

* **duplicates** (:func:`duplicates`): two views whose pattern points lie within
  :data:`DUPLICATE_FRACTION` of the image diagonal of each other (and within 4 times that
  fraction of the pattern's own diagonal in the image, for a small pattern; RMS over the
  points, in either order of the pattern, which a symmetric board may be detected in) are
  one view; the later ones are not used, and fewer than :data:`MIN_VIEWS` distinct views
  are refused;
* **coverage** (:func:`coverage`): the fraction of the image covered by the union of the
  pattern's outlines (convex hulls) over the views; under :data:`MIN_COVERAGE` is warned
  about (the distortion at the edges is extrapolated);
* **tilt spread** (:func:`tilt_spread_deg`): the largest angle between the pattern's normals
  over the fitted poses; under :data:`MIN_TILT_SPREAD_DEG` is warned about (nearly parallel
  views leave the focal length poorly determined).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from redservo._validation import FloatArray

__all__ = [
    "DUPLICATE_FRACTION",
    "MIN_COVERAGE",
    "MIN_TILT_SPREAD_DEG",
    "MIN_VIEWS",
    "coverage",
    "duplicates",
    "tilt_spread_deg",
]

MIN_VIEWS = 3
"""Fewest distinct views a calibration accepts."""
DUPLICATE_FRACTION = 0.005
"""Two views whose points differ by less than this fraction of the image diagonal (RMS, e.g.
2.5 px in a 400 x 300 image) are the same view."""
MIN_COVERAGE = 0.25
"""A smaller fraction of the image covered by the pattern over all views is warned about."""
MIN_TILT_SPREAD_DEG = 10.0
"""A smaller largest angle between two views' pattern normals (degrees) is warned about."""


def _rms(a: FloatArray, b: FloatArray) -> float:
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1))))


def duplicates(points: Sequence[FloatArray], shape: tuple[int, int]) -> dict[int, int]:
    """``{k: j}``: view ``k`` repeats the earlier view ``j`` (``points``: (N, 2) px per view,
    ``shape``: ``(height, width)`` px)."""
    image_tol = DUPLICATE_FRACTION * float(np.hypot(*shape))
    kept: list[int] = []
    same: dict[int, int] = {}
    for k, p in enumerate(points):
        extent = float(np.hypot(*np.ptp(p, axis=0)))
        tol = min(image_tol, 4.0 * DUPLICATE_FRACTION * extent)
        for j in kept:
            q = points[j]
            if p.shape == q.shape and min(_rms(p, q), _rms(p, q[::-1])) < tol:
                same[k] = j
                break
        else:
            kept.append(k)
    return same


def coverage(cv2: Any, points: Sequence[FloatArray], shape: tuple[int, int]) -> float:
    """Fraction (0..1) of the image covered by the union of the views' convex hulls."""
    mask = np.zeros(shape, np.uint8)
    for p in points:
        hull = cv2.convexHull(np.asarray(p, dtype=np.float32).reshape(-1, 1, 2))
        cv2.fillConvexPoly(mask, np.round(hull).astype(np.int32), 1)
    return float(mask.mean())


def tilt_spread_deg(poses: Sequence[FloatArray]) -> float:
    """The largest angle (degrees) between the pattern's normals of two poses ``cMo`` (4x4)."""
    n = np.array([T[:3, 2] for T in poses])
    if len(n) < 2:
        return 0.0
    cos = np.clip(n @ n.T, -1.0, 1.0)
    return float(np.degrees(np.arccos(cos.min())))
