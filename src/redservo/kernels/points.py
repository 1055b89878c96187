"""Image-point kernels without temporaries: a point in the camera frame, its interaction rows in place.

:mod:`redservo.kernels.features` measures points and builds their interaction matrices
with these, and the compiled campaign loop (:mod:`redservo.kernels.loop_task`) calls them
at every step, writing into its own arrays: the same arithmetic on every path. Units: m,
normalized image coordinates.
"""

from __future__ import annotations

from typing import Any

from redservo.kernels._jit import kernel

__all__ = ["camera_point", "point_interaction_into"]


@kernel
def camera_point(cMo: Any, pts: Any, k: int) -> Any:
    """``(X, Y, Z)`` (m) of point ``k`` of ``pts`` (N, 3, object frame) in the camera frame
    ``cMo`` (4, 4): ``cMo[:3, :3] p + cMo[:3, 3]``, each row summed left to right."""
    X = cMo[0, 0] * pts[k, 0] + cMo[0, 1] * pts[k, 1] + cMo[0, 2] * pts[k, 2] + cMo[0, 3]
    Y = cMo[1, 0] * pts[k, 0] + cMo[1, 1] * pts[k, 1] + cMo[1, 2] * pts[k, 2] + cMo[1, 3]
    Z = cMo[2, 0] * pts[k, 0] + cMo[2, 1] * pts[k, 1] + cMo[2, 2] * pts[k, 2] + cMo[2, 3]
    return X, Y, Z


@kernel
def point_interaction_into(x: float, y: float, inv_z: float, L: Any, row: int) -> None:
    """:func:`point_interaction` written into rows ``row`` and ``row + 1`` of ``L`` (k, 6)
    (no temporary: what the compiled loop calls at every step); ``inv_z`` in 1/m."""
    L[row, 0] = -inv_z
    L[row, 1] = 0.0
    L[row, 2] = x * inv_z
    L[row, 3] = x * y
    L[row, 4] = -(1.0 + x * x)
    L[row, 5] = y
    L[row + 1, 0] = 0.0
    L[row + 1, 1] = -inv_z
    L[row + 1, 2] = y * inv_z
    L[row + 1, 3] = 1.0 + y * y
    L[row + 1, 4] = -x * y
    L[row + 1, 5] = -x
