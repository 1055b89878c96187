"""The compiled engine's :class:`~redservo.control.ControlStep`, made from the kernel's buffer
when read.

:func:`redservo.control.engine.quick_step` (the step a loop repeats) ends with the kernel's
buffer (the command, ``e``, ``e1``, ``L``, ``J1``, the law's raw outputs and the kernel's
copy of ``q``, laid out by :func:`redservo.kernels.control.control_layout`) and its event
masks. The
command, the :class:`~redservo.task.TaskState` and the law's diagnostics are then made from
them on their first read (:class:`KernelStep`), with the same values bit for bit as
:func:`redservo.binding.control.results` makes them at once; a loop that sends only
``step.qdot`` pays for nothing else (issue 29 item 3).

The buffer is this step's own (a new one at every step) and nothing writes into it after the
kernel: ``qdot`` is a copy of its part, so a caller writing into its command changes neither
the command history (which copies the buffer's part into its ring,
:mod:`redservo.control.latency`) nor the diagnostics; the task state's arrays are views of
it, as on the full path.

Units: as :class:`~redservo.control.ControlStep`'s (rad/s or m/s, s, normalized image units).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from redservo._validation import FloatArray
from redservo.control.steps import ControlStep
from redservo.records.lazy import lazy_field
from redservo.redundancy.base import Diagnostics, LazyDiagnostics
from redservo.redundancy.kernel_call import diagnose
from redservo.task import TaskState

if TYPE_CHECKING:
    from redservo.binding.control import CompiledControl

__all__ = ["KernelStep", "StepSource"]

StepSource = tuple[Any, ...]
"""``(engine, buf, s, inv_depth, (law mask, safety mask, vec))``: what the kernel's step
made (:class:`~redservo.binding.control.CompiledControl` ``engine``, with the law's options
of this step; ``buf`` its own buffer, with the kernel's copy of the joints ``q`` (n,);
``s`` (k,) and ``inv_depth`` as the step took them)."""

_new_state: Callable[[type[TaskState], tuple[object, ...]], TaskState] = tuple.__new__
_new_lazy = object.__new__
_set = object.__setattr__


class KernelStep(ControlStep):
    """A :class:`~redservo.control.ControlStep` of the compiled engine's quick step: its
    command, task state and diagnostics made from a :data:`StepSource` when first read
    (module docstring); no feed-forward, secondary command, stop or saturation."""

    __slots__ = ()
    secondary = None
    de1_dt = None
    stop = None
    saturated = False

    @lazy_field
    def qdot(self) -> FloatArray:
        src = self._src
        return src[1][src[0].task_slices[0]].copy()

    @lazy_field
    def state(self) -> TaskState:
        eng, buf, s, inv_depth = self._src[:4]
        _, se, se1, sJ1, sL = eng.task_slices
        m, n, k = eng.shapes
        e = buf[se]
        e1 = e if eng.no_C else buf[se1]
        L, J1 = buf[sL].reshape(k, 6), buf[sJ1].reshape(m, n)
        return _new_state(TaskState, (s, e, e1, L, J1, inv_depth))

    @lazy_field
    def diagnostics(self) -> Diagnostics:
        return kernel_diagnostics(*self._src)


def kernel_diagnostics(
    eng: CompiledControl,
    buf: FloatArray,
    s: FloatArray,
    inv_depth: tuple[FloatArray, ...],
    masks: tuple[int, int, FloatArray],
) -> Diagnostics:
    """The law's diagnostics of a :data:`StepSource`, built when first read
    (:class:`~redservo.redundancy.base.LazyDiagnostics`, as
    :func:`redservo.binding.control.results` makes them): from the law part of ``buf``
    (``qdot`` to ``ssrc``), the law's options as the engine bound them and, when the
    safety layer raised events, the kernel's copy of ``q`` (its part of ``buf``, which
    nothing writes into) and a copy of the command."""
    safety = None
    if masks[1]:
        safety = (buf[eng.q_part], buf[eng.task_slices[0]].copy(), eng.gains[1], eng.limits)
    args = (type(eng.law), eng.law_state, eng.shapes[0], buf, eng.law_slices, masks, safety)
    diag = _new_lazy(LazyDiagnostics)
    _set(diag, "_build", (diagnose, args))
    return diag
