"""The compiled evaluation of a task of image points (the object path's hot path).

:meth:`redservo.task.VisualTask.evaluate` calls :func:`evaluate` on the common task (the
points of one target, current depth, no noise) when the kernels are compiled: one call of
:func:`redservo.kernels.points_task.points_task`, from the camera pose to ``J1``, with the
numpy path's numbers to the bit. It returns None whenever an input is not as the kernel
takes it (float64, C-contiguous), a point is behind the camera, ``bMc`` fails the
kernel's sufficient test of a transform or the target's pose cannot be read: the task then
runs its numpy path, whose checks accept the input or raise the one error naming it, in
their documented order. (``evaluate_measured`` keeps its numpy calls: the same kernel from
measured points saved nothing measurable, its checks of the inputs cost what it saved.)
Units: m, rad, 1/m; normalized image units.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from redservo._validation import FloatArray
from redservo.features.plan import PointGroup
from redservo.kernels import lazy
from redservo.scene import Scene

if TYPE_CHECKING:  # the kernel module, typed; imported on first use at run time
    from redservo.kernels import points_task as _KT
else:
    _KT = lazy("points_task")

__all__ = ["compiled", "evaluate"]

_F64 = np.dtype(np.float64)
_NO_C = np.zeros((0, 0))

Rows = tuple[FloatArray, FloatArray, FloatArray, FloatArray]
"""``(e, e1, L, J1)``: the error (k,), ``C e`` (m,), ``L`` (k, 6) and ``J1`` (m, n)."""


def compiled() -> bool:
    """True when the kernels are compiled (else the task keeps its numpy path)."""
    return bool(_KT.COMPILED)


def _ready(a: FloatArray) -> bool:
    """``a`` is a C-contiguous float64 array (as the kernel takes it without a copy)."""
    return a.dtype == _F64 and a.flags.c_contiguous


def evaluate(
    scene: Scene,
    group: PointGroup,
    bMc: FloatArray,
    J: FloatArray,
    t: float,
    task: tuple[FloatArray, FloatArray | None],
) -> tuple[FloatArray, FloatArray, Rows] | None:
    """``(s, 1/Z, (e, e1, L, J1))`` of the points of ``group`` seen from ``bMc`` (4, 4) at
    ``t`` (s), with the model Jacobian ``J`` (6, n) and the task's ``(s*, C)`` (``C`` None:
    ``e1`` is ``e`` itself), or None (module docstring)."""
    s_star, C = task
    if not (
        type(J) is np.ndarray
        and J.ndim == 2
        and J.shape[0] == 6
        and type(bMc) is np.ndarray
        and bMc.shape == (4, 4)
        and J.dtype == _F64
        and J.flags.c_contiguous
        and bMc.dtype == _F64
        and bMc.flags.c_contiguous
        and _ready(s_star)
        and (C is None or (type(C) is np.ndarray and _ready(C)))
    ):
        return None
    try:  # bMc is checked by the kernel; the numpy path raises in the documented order
        bMw, wMo = scene._target_pose(group.target_name, t)
    except Exception:
        return None
    if not (type(wMo) is np.ndarray and _ready(wMo)):
        return None
    Ck = _NO_C if C is None else C
    s, iz, bad, e, e1, L, J1 = _KT.points_task(bMc, bMw, wMo, group.points, s_star, Ck, J)
    if bad != -1:  # a point behind the camera, or bMc not surely valid
        return None
    return s, iz, (e, e if C is None else e1, L, J1)
