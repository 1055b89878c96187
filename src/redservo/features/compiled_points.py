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

from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.features.plan import PointGroup
from redservo.kernels import lazy
from redservo.kernels.entry import Spares, entry_of
from redservo.scene import Scene

if TYPE_CHECKING:  # the kernel module, typed; imported on first use at run time
    from redservo.kernels import points_task as _KT
    from redservo.task import VisualTask
else:
    _KT = lazy("points_task")

__all__ = ["Hot", "compiled", "evaluate"]

_F64 = np.dtype(np.float64)
_NO_C = np.zeros((0, 0))

State = tuple[Any, ...]
"""``(s, e, e1, L, J1, inv_depth)``: the fields of a :class:`~redservo.task.TaskState`."""
_ND = np.ndarray
_SHAPE44 = (4, 4)


def compiled() -> bool:
    """True when the kernels are compiled (else the task keeps its numpy path)."""
    return bool(_KT.COMPILED)


def _ready(a: FloatArray) -> bool:
    """``a`` is a C-contiguous float64 array (as the kernel takes it without a copy)."""
    return a.dtype == _F64 and a.flags.c_contiguous


class Hot:
    """What a task's compiled evaluation keeps between calls (on the task, :data:`_HOT`):
    its ``s*`` and ``C`` objects with the kernel's form of ``C``, and the kernel's entry
    point (:mod:`redservo.kernels.entry`) with the kernel module handle and the scene it was found for
    (``bMw``'s type comes from the scene). A task whose ``s_star`` or ``C`` was set since gets a new one."""

    __slots__ = ("C", "Ck", "J_shape", "entry", "k", "kernel", "m", "s_star", "scene", "spares")

    def __init__(self, s_star: FloatArray, C: FloatArray | None) -> None:
        self.s_star, self.C = s_star, C
        self.Ck = _NO_C if C is None else C
        self.k = s_star.shape[0]
        """The number of point coordinates (2N)."""
        self.m = self.k if C is None else C.shape[0]
        """The task's rows."""
        self.spares: Spares | None = None
        self.J_shape: tuple[int, ...] = ()
        """The shape of ``J`` the spares and the entry are for."""
        """The arrays the kernel writes ``(s, iz, e, e1, L, J1)`` into, for the ``n`` of
        the last call (:class:`~redservo.kernels.entry.Spares`)."""
        self.entry: Any = None
        self.kernel: object = None
        self.scene: object = None

    def __reduce__(self) -> tuple[Any, ...]:
        """A pickled or copied task forgets its record (the kernel's entry point is not
        picklable): its next evaluation makes a new one."""
        return (_forgotten, ())


_HOT = "_points_hot"
"""Where a task keeps its :class:`Hot`."""


def _forgotten() -> None:
    """What a pickled :class:`Hot` becomes."""
    return None


def _hot(task: VisualTask, group: PointGroup) -> Hot | None:
    """A new :class:`Hot` for the task's ``s*`` and ``C`` (kept on the task), or None when
    they are not as the kernel takes it (``s*`` (2N,) for the N points of ``group``, ``C``
    (m, 2N))."""
    s_star, C = task.s_star, task.C
    k = 2 * group.points.shape[0]
    if not (
        type(s_star) is np.ndarray
        and _ready(s_star)
        and s_star.shape == (k,)
        and (C is None or (type(C) is np.ndarray and _ready(C) and C.ndim == 2))
        and (C is None or C.shape[1] == k)
    ):
        return None
    hot = task.__dict__[_HOT] = Hot(s_star, C)
    return hot


def evaluate(
    scene: Scene, task: VisualTask, group: PointGroup, bMc: object, J: object, t: float
) -> State | None:
    """``(s, e, e1, L, J1, inv_depth)`` (a :class:`~redservo.task.TaskState`'s fields) of
    the points of ``group`` seen from ``bMc`` (4, 4) at ``t`` (s), with the model Jacobian
    ``J`` (6, n) and the ``s*`` and ``C`` of ``task`` (``C`` None: ``e1`` is ``e`` itself),
    or None (module docstring). Float64 arrays that are also aligned and writeable
    (``flags.carray``) of the shapes of the last such call, with its scene, go to the
    kernel's entry point (the same machine code, without numba's typing of the eight
    arguments), with no other look at them: the kernel checks ``bMc``'s values."""
    hot: Hot | None = task.__dict__.get(_HOT)
    if (
        hot is not None
        and hot.entry
        and hot.scene is scene
        and hot.s_star is task.s_star
        and hot.C is task.C
        and type(J) is _ND
        and type(bMc) is _ND
        and J.shape == hot.J_shape
        and bMc.shape == _SHAPE44
        and J.dtype == _F64
        and bMc.dtype == _F64
        and J.flags.carray
        and bMc.flags.carray
        and hot.kernel is _KT
        and compiled()  # the kernels off (a test, a plain run) take the numpy path
    ):
        try:  # a trajectory or pose set since is read at every call
            bMw, wMo = scene._target_pose(group.target_name, t)
        except Exception:
            return None
        if type(wMo) is _ND and wMo.dtype == _F64 and wMo.flags.carray:
            out = hot.spares.take()  # type: ignore[union-attr]  # set with the entry
            if hot.entry(bMc, bMw, wMo, group.points, hot.s_star, hot.Ck, J, out[:6]) != -1:
                return None  # a point behind the camera, or bMc not surely valid
            return _state(hot, group, out)
    return _evaluate(scene, task, group, bMc, J, t)


class _Split:
    """The per-term (1,) views of a set's inverse depths (its second array), made once with
    the set (:class:`~redservo.kernels.entry.Spares`)."""

    __slots__ = ("split",)

    def __init__(self, split: Any) -> None:
        self.split = split

    def __call__(self, arrays: tuple[FloatArray, ...]) -> tuple[FloatArray, ...]:
        return tuple(self.split(arrays[1]))

    def __reduce__(self) -> tuple[Any, ...]:
        return (_Split, (self.split,))


def _state(hot: Hot, group: PointGroup, out: tuple[FloatArray, ...]) -> State:
    """The state's fields from the arrays the kernel wrote, ``out`` (never handed out
    itself: the state holds its arrays, so :class:`~redservo.kernels.entry.Spares` sees
    them held)."""
    s, _, e, e1, L, J1, inv_depth = out[:7]
    return s, e, e if hot.C is None else e1, L, J1, inv_depth


def _evaluate(
    scene: Scene, task: VisualTask, group: PointGroup, bMc: object, J: object, t: float
) -> State | None:
    """:func:`evaluate` through the kernel's dispatcher: its first call, or another
    signature; finds the entry for the next calls when the arrays are plain."""
    if not (
        compiled()
        and type(J) is np.ndarray
        and type(bMc) is np.ndarray
        and J.ndim == 2
        and J.shape[0] == 6
        and bMc.shape == (4, 4)
        and J.dtype == _F64
        and bMc.dtype == _F64
    ):
        return None
    fJ, fb = J.flags, bMc.flags
    hot: Hot | None = task.__dict__.get(_HOT)
    if hot is None or hot.s_star is not task.s_star or hot.C is not task.C:
        hot = _hot(task, group)
    if hot is None or not (fJ.c_contiguous and fb.c_contiguous):
        return None
    try:  # bMc is checked by the kernel; the numpy path raises in the documented order
        bMw, wMo = scene._target_pose(group.target_name, t)
    except Exception:
        return None
    if not (type(wMo) is np.ndarray and wMo.dtype == _F64):
        return None
    fw = wMo.flags
    if not fw.c_contiguous:
        return None
    spares = hot.spares
    if spares is None or hot.J_shape != J.shape:
        k, m = hot.k, hot.m
        shapes = ((k,), (k >> 1,), (k,), (m,), (k, 6), (m, J.shape[1]))
        spares = hot.spares = Spares(shapes, _Split(group.split))
        hot.J_shape, hot.entry = J.shape, None  # an entry is for the shapes it was found with
    out = spares.take()
    args = (bMc, bMw, wMo, group.points, hot.s_star, hot.Ck, J, out[:6])
    kernel = _KT.points_task
    bad = kernel(*args)
    if fJ.carray and fb.carray and fw.carray:
        hot.entry, hot.kernel, hot.scene = entry_of(kernel, args), _KT, scene
    if bad != -1:  # a point behind the camera, or bMc not surely valid
        return None
    return _state(hot, group, out)
