"""The simulation loop's image check of point-set targets in one compiled call: the targets'
camera points (:func:`redservo.kernels.dot_pixels.dot_points`, :meth:`redservo.scene.Scene.cMo`'s
products with the same operations) and :func:`redservo.kernels.in_image.points_in_image`
on all of them (:mod:`redservo.simulation.loop_image`). Units: metres, pixels.
"""

from __future__ import annotations

from typing import Any

from redservo.kernels._jit import kernel
from redservo.kernels.dot_pixels import dot_points
from redservo.kernels.in_image import points_in_image

__all__ = ["targets_in_image"]


@kernel
def targets_in_image(
    bMc: Any,
    wMo: Any,
    bMw: Any,
    has_base: bool,
    pts: Any,
    starts: Any,
    intrinsics: Any,
    bounds: Any,
) -> int:
    """:func:`~redservo.kernels.in_image.points_in_image` (1, 0 or -1) of the camera points of
    the point sets ``pts[starts[s]:starts[s + 1]]`` (object frames, m) at the camera pose
    ``bMc`` (1, 4, 4) and object poses ``wMo`` (1, sets, 4, 4), the base ``bMw`` when
    ``has_base`` (arguments as :func:`~redservo.kernels.dot_pixels.dot_points`)."""
    P = dot_points(bMc, wMo, bMw, has_base, pts, starts)
    return points_in_image(P[0], intrinsics, bounds)
