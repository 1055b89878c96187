"""A task of image points of one target evaluated in one compiled call (the object path's hot path).

:meth:`redservo.task.VisualTask.evaluate` on the common task (the points of one target,
current depth, no noise) calls :func:`points_task` once instead of six numpy and kernel
calls. It chains the kernels the compiled steps already share, in the object path's order,
so the numbers are those of the numpy path to the bit (tests/test_task_kernel_path.py):

1. ``cMo = inverse(bMc) [· bMw] · wMo`` (:meth:`redservo.scene.Scene.cMo`; the inverse of
   :func:`redservo.kernels.loop_task.inverse`, ``-Rᵀt`` by BLAS as
   :func:`redservo.spatial.inverse`; products by BLAS as numpy's ``@``);
2. the points' ``s`` and ``1/Z`` (:func:`redservo.kernels.features.points_measure`) and
   ``L`` (:func:`~redservo.kernels.features.points_interaction`);
3. ``e = s − s*``, then CM01 eq. 25 by the step kernel's
   :func:`redservo.kernels.control.task_rows` (``e1 = C e``, ``J1 = (C L) J``).

``COMPILED`` (re-exported from :mod:`redservo.kernels._jit`) tells the caller whether the
kernel is compiled; uncompiled (``REDSERVO_KERNELS=python``), the task keeps its numpy path.
Units: m, rad; features in normalized image units, inverse depths in 1/m.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import COMPILED, kernel
from redservo.kernels.control import task_rows
from redservo.kernels.features import points_interaction, points_measure
from redservo.kernels.loop_task import inverse

__all__ = ["COMPILED", "points_task"]


@kernel
def points_task(bMc: Any, bMw: Any, wMo: Any, pts: Any, s_star: Any, C: Any, J: Any) -> Any:
    """``(s, 1/Z, bad, e, e1, L, J1)`` of the N points ``pts`` (N, 3; object frame, m) of a
    target at ``wMo`` (4, 4; world frame) seen from the camera pose ``bMc`` (4, 4; base
    frame, validated by the caller); ``bMw`` (4, 4) the world in the base frame, or a (0, 0)
    array when the base is at the world origin (the product is skipped, as
    :meth:`~redservo.scene.Scene.cMo` skips it); ``s_star`` (2N,); ``C`` (m, 2N) or a (0, 0)
    array for none; ``J`` (6, n) the robot Jacobian.

    ``bad`` is the first point at or behind the camera (-1: none); then only ``s``, ``1/Z``
    and ``bad`` are meaningful (``L`` and ``J1`` are empty) and the caller raises the
    point's own error through the object path.
    """
    cMw = inverse(bMc)
    if bMw.shape[0] != 0:
        cMw = np.dot(cMw, bMw)
    cMo = np.dot(cMw, wMo)
    s, iz, bad = points_measure(cMo, pts)
    k = s.shape[0]
    if bad >= 0:
        return s, iz, bad, s, s, np.empty((0, 6)), np.empty((0, J.shape[1]))
    L = points_interaction(s, iz)
    e = np.empty(k)
    for i in range(k):
        e[i] = s[i] - s_star[i]
    e1, J1 = task_rows(e, L, C, J)
    return s, iz, bad, e, e1, L, J1
