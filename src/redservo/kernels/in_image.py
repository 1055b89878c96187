"""The simulation loop's image check in one compiled call: every camera-frame point in
front of the camera and its pixel within the image less a margin
(:func:`redservo.simulation.loop`'s check that an object stays in view), for a camera
without distortion, with the roundings of the numpy code it replaces (``X/Z``, then
``x px``, then ``+ u0``; the bounds ``width - margin`` computed by the caller).
Units: metres, pixels.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["points_in_image"]


@kernel
def points_in_image(P: Any, intrinsics: Any, bounds: Any) -> int:
    """1 when every point of ``P`` (N, 3) (m, camera frame) has ``Z > 1e-9`` and its
    pixel ``(u0 + px X/Z, v0 + py Y/Z)`` lies in ``[m, width - m] × [m, height - m]``,
    0 when one does not; -1 when a normalized coordinate is not finite (the caller's
    numpy code raises its error). ``intrinsics`` ``(px, py, u0, v0)``, ``bounds`` ``(m,
    width - m, height - m)``."""
    px, py, u0, v0 = intrinsics
    m, wm, hm = bounds
    n = P.shape[0]
    for i in range(n):
        if P[i, 2] <= 1e-9:
            return 0
    inside = 1
    for i in range(n):
        x = P[i, 0] / P[i, 2]
        y = P[i, 1] / P[i, 2]
        if not (np.isfinite(x) and np.isfinite(y)):
            return -1
        ux = x * px
        u = ux + u0
        vy = y * py
        v = vy + v0
        if not (u >= m and u <= wm and v >= m and v <= hm):
            inside = 0
    return inside
