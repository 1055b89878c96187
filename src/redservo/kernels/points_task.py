"""A task of image points of one target evaluated in one compiled call (the object path's hot path).

:meth:`redservo.task.VisualTask.evaluate` on the common task (the points of one target,
current depth, no noise) calls :func:`points_task` once instead of six numpy and kernel
calls. It chains the kernels the compiled steps already share, in the object path's order,
so the numbers are those of the numpy path to the bit (tests/test_task_kernel_path.py):

0. a test that ``bMc`` is a valid transform (:func:`transform_ok`: a sufficient condition
   for :func:`redservo._validation.as_transform`'s, with half its tolerances; a pose it
   refuses goes to the object path's own check, which accepts it or raises its error);
1. ``cMo = inverse(bMc) [· bMw] · wMo`` (:meth:`redservo.scene.Scene.cMo`; the inverse of
   :func:`redservo.kernels.loop_task.inverse`, ``-Rᵀt`` by BLAS as
   :func:`redservo.spatial.inverse`; products by BLAS as numpy's ``@``);
2. the points' ``s`` and ``1/Z`` (:func:`redservo.kernels.features.points_measure`) and
   ``L`` (:func:`~redservo.kernels.features.points_interaction`);
3. ``e = s − s*``, then the task rows by the step kernel's
   :func:`redservo.kernels.control.task_rows` (``e1 = C e``, ``J1 = (C L) J``).

``COMPILED`` (re-exported from :mod:`redservo.kernels._jit`) tells the caller whether the
kernel is compiled; uncompiled (``REDSERVO_KERNELS=python``), the task keeps its numpy path.
Units: m, rad; features in normalized image units, inverse depths in 1/m.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import COMPILED, kernel
from redservo.kernels.control import points_rows
from redservo.kernels.features import points_measure
from redservo.kernels.loop_task import inverse

__all__ = ["COMPILED", "points_rows", "points_task", "transform_ok"]

BOTTOM_TOL, ROTATION_TOL = 0.5e-9, 0.5e-6
"""Half the tolerances of ``as_transform`` (bottom row; ``R Rᵀ = I`` per entry): a rounding
difference between two evaluations of the same formula (~1e-16) cannot make this test
accept a pose that ``as_transform`` refuses."""


@kernel
def transform_ok(T: Any) -> bool:
    """``T`` (4, 4) passes ``as_transform``'s checks with margin: every entry below 1e300 in
    magnitude (so finite, and their sum too), the bottom row ``(0, 0, 0, 1)`` within
    :data:`BOTTOM_TOL`, the rows of ``R`` orthonormal within :data:`ROTATION_TOL` and
    ``det R > 0.5`` (a rotation has 1, a reflection -1). False sends the pose to the Python
    check, which names what is wrong or accepts a pose within its full tolerances."""
    for r in range(4):
        for c in range(4):
            if not abs(T[r, c]) < 1e300:  # NaN fails too
                return False
    for c in range(3):
        if not abs(T[3, c]) <= BOTTOM_TOL:
            return False
    if not abs(T[3, 3] - 1.0) <= BOTTOM_TOL:
        return False
    for r in range(3):
        for r2 in range(r, 3):
            dot = T[r, 0] * T[r2, 0] + T[r, 1] * T[r2, 1] + T[r, 2] * T[r2, 2]
            if not abs(dot - (1.0 if r == r2 else 0.0)) <= ROTATION_TOL:
                return False
    a, b, c, d, e, f = T[0, 0], T[0, 1], T[0, 2], T[1, 0], T[1, 1], T[1, 2]
    g, h, i = T[2, 0], T[2, 1], T[2, 2]
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0.5


@kernel
def points_task(
    bMc: Any, bMw: Any, wMo: Any, pts: Any, s_star: Any, C: Any, J: Any, out: Any
) -> int:
    """``bad``, with ``(s, 1/Z, e, e1, L, J1)`` of the N points ``pts`` (N, 3; object frame,
    m) of a target at ``wMo`` (4, 4; world frame) seen from the camera pose ``bMc`` (4, 4;
    base frame) written into the caller's float64 arrays ``out`` = ``(s, iz, e, e1, L, J1)``
    of shapes (2N,), (N,), (2N,), (m,), (2N, 6), (m, n); ``bMw`` (4, 4) the world in the
    base frame, or a (0, 0) array when the base is at the world origin (the product is
    skipped, as :meth:`~redservo.scene.Scene.cMo` skips it); ``s_star`` (2N,); ``C`` (m, 2N)
    or a (0, 0) array for none (``e1`` is then ``e`` and its array is not written); ``J``
    (6, n) the robot Jacobian. Writing into arrays the caller made costs less than
    returning six new ones (numba boxes each returned array: ≈ 0.4 µs apiece).

    ``bad`` is the first point at or behind the camera (-1: none), or -2 when ``bMc`` fails
    :func:`transform_ok`; then ``out`` is not (fully) written and the caller takes the
    object path, which raises the error (or accepts a pose within the full tolerances).
    """
    if not transform_ok(bMc):
        return -2
    cMw = inverse(bMc)
    if bMw.shape[0] != 0:
        cMw = np.dot(cMw, bMw)
    cMo = np.dot(cMw, wMo)
    s, iz, bad = points_measure(cMo, pts)
    if bad >= 0:
        return bad
    e, e1, L, J1 = points_rows(s, iz, s_star, C, J)
    s_out, iz_out, e_out, e1_out, L_out, J1_out = out
    s_out[:] = s
    iz_out[:] = iz
    e_out[:] = e
    if C.shape[0] != 0:
        e1_out[:] = e1
    L_out[:, :] = L
    J1_out[:, :] = J1
    return -1
