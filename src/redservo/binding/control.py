"""The compiled engine of a :class:`~redservo.control.Controller` (pure Python glue).

:func:`bind_controller` packs a controller's robot, task, law and limits once for the
kernels of :mod:`redservo.kernels.control`; :meth:`CompiledControl.step` then runs the
kinematics, ``e1``, ``J1``, the law, its safety layer and the flag rules in one compiled
call, and builds the :class:`~redservo.task.TaskState` and the law's
:class:`~redservo.Diagnostics` from the kernel's buffer with the law's own ``diagnose``
(the method its Python call uses): the command, the task state and the diagnostics are bit
for bit those of the object path (``task.evaluate_measured`` then ``law(...)``).

Covered: tasks of image points (any depth option), the robots with compiled kinematics
(Afma6, DH chains, chains such as URDF robots; any other robot with the Jacobian from
Python), the laws with a compiled step and a ``diagnose`` method, a fixed or adaptive gain
λ, uniform scaling. Anything else gets a reason (one line) and the controller runs the object path.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from redservo._validation import FloatArray
from redservo.binding.control_law import control_kernels, control_pack, law_reason, stale
from redservo.features import plan as plan
from redservo.kernels import lazy
from redservo.kernels.entry import entry_of
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics, Law, LazyDiagnostics
from redservo.redundancy.gain import AdaptiveGain, gain_value
from redservo.redundancy.kernel_call import _PACK, LAW_PARTS, diagnose
from redservo.redundancy.packs import limits_pack
from redservo.robots.base import Robot
from redservo.task import TaskState, VisualTask

__all__ = ["CompiledControl", "bind_controller", "law_reason", "results", "stale"]

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import control as _K
else:
    _K = lazy("control")
_NO_C = np.zeros((0, 0))
_F64 = np.dtype(np.float64)
_new_state: Callable[[type[TaskState], tuple[object, ...]], TaskState] = tuple.__new__
"""``TaskState(...)`` from its six fields in order, without the keyword handling (hot path)."""
_EMPTY = np.zeros(0)
_new_lazy = object.__new__
_set = object.__setattr__


@dataclass(frozen=True)
class CompiledControl:
    """A controller's set-up packed for :mod:`redservo.kernels.control` (module docstring)."""

    kernel: Callable[..., Any] | None
    """The kernel with the robot's kinematics, or None: the Jacobian comes from Python."""
    robot: tuple[Any, ...]
    """The robot pack (empty for a robot without compiled kinematics)."""
    jacobian: Callable[[FloatArray], FloatArray]
    """The robot object's model Jacobian (6, n) at ``q``, when the caller gives none and
    there is no compiled kinematics."""
    law_pack: tuple[Any, ...]
    limits_pack: tuple[Any, ...]
    s_star: FloatArray
    C: FloatArray
    law: Law
    limits: JointLimits
    task: VisualTask
    gains: tuple[float, float]
    """``(λ, dt)`` (1/s, s); λ is NaN for an adaptive gain (:attr:`adaptive`)."""
    adaptive: AdaptiveGain | None
    """The adaptive gain λ(‖e1‖∞), evaluated at each step as the law would, or None."""
    depth_scale: float
    law_slices: tuple[slice, ...]
    """The law's parts of the kernel's buffer, ``qdot`` to ``ssrc`` in the order of
    :func:`redservo.kernels.control.control_layout` (what the law's ``diagnose`` reads)."""
    task_slices: tuple[slice, ...]
    """The parts ``qdot``, ``e``, ``e1``, ``J1``, ``L`` of the kernel's buffer (the command
    and the task state), found by name in the layout."""
    q_part: slice
    """The kernel's copy of ``q`` in its buffer (the quick step's diagnostics read it)."""
    size: int
    shapes: tuple[int, int, int]
    """``(m, n, k)``: the task's rows, the joints and the point coordinates."""
    q_shape: tuple[int]
    """``(n,)``: the shape of ``q`` and ``qdot_prev``."""
    s_shape: tuple[int]
    """``(k,)``: the shape of ``s``."""
    iz_shape: tuple[int]
    """``(N,)``: one inverse depth per point."""
    depth_option: bool
    """The inverse depths go through the task's depth option or the depth scale."""
    no_C: bool
    """The task has no combination matrix (``e1 = e``)."""
    spare: list[FloatArray]
    """``[buffer]``: the kernel's buffer (:attr:`size`) of the last quick step
    (:func:`redservo.control.engine.quick_step`), which the next one reuses when nothing
    else holds it any more (no step, task state, view or lazy diagnostics of it: its
    reference count says so); else the next step takes a new one."""
    iz_buffer: FloatArray = field(default_factory=lambda: np.zeros(0))
    """(N,) float64: the inverse depths of :func:`redservo.control.engine.quick_step`'s
    step, written in place (the kernel reads them and keeps nothing)."""
    iz_rows: FloatArray = field(default_factory=lambda: np.zeros((0, 1)))
    """:attr:`iz_buffer` as (N, 1): one row per point, as the inverse depths come."""
    iz_bytes: memoryview = field(default_factory=lambda: memoryview(b""))
    """:attr:`iz_buffer`'s bytes (:func:`redservo.binding.depths.take_inverse_depths`)."""
    law_token: object = None
    """What the law keeps while its options are those of :attr:`law_pack` (its packed
    options, :func:`redservo.redundancy.kernel_call._law_pack`: setting one of its public
    attributes drops it): :func:`stale` compares it at every step."""
    law_state: dict[str, Any] = field(default_factory=dict)
    """The law's attributes when bound (its options, what ``diagnose`` reads; no one
    changes this dictionary): the same at every step until the law changes (:func:`stale`)."""
    entry: list[Callable[..., Any] | bool | None] = field(default_factory=lambda: [None])
    """The entry point of :attr:`kernel`'s compiled version for this set-up's argument
    types, once a step found it (:func:`redservo.kernels.entry.entry_of`); None before,
    False when there is none (no numba)."""
    measured_entry: list[Callable[..., Any] | bool | None] = field(default_factory=lambda: [None])
    """:attr:`entry` of :attr:`measured`, the step with the model Jacobian given (a loop
    that has it: the simulator's image runs)."""
    measured: Callable[..., Any] | None = None
    """The law's step with the model Jacobian given
    (:func:`~redservo.kernels.control.measured_control`, or the law's own:
    :func:`redservo.binding.control_law.control_kernels`); None: ``measured_control``."""

    @cached_property
    def hot(self) -> tuple[Any, ...]:
        """What :func:`redservo.control.engine.quick_step` reads at every step, in one
        attribute: ``(robot, s_star, C, law_pack, limits_pack, gains, size, q_shape,
        s_shape, the command's part of the buffer, the law's attribute dictionary,
        law_token)``."""
        return (
            self.robot,
            self.s_star,
            self.C,
            self.law_pack,
            self.limits_pack,
            self.gains,
            self.size,
            self.q_shape,
            self.s_shape,
            self.task_slices[0],
            self.law.__dict__,
            self.law_token,
        )

    def step(
        self,
        q: FloatArray,
        s: FloatArray,
        inv_depth: Sequence[FloatArray],
        qdot_prev: FloatArray | None,
        *,
        J: FloatArray | None = None,
        de1_dt: FloatArray | None = None,
        secondary: FloatArray | None = None,
    ) -> tuple[FloatArray, TaskState, Diagnostics, tuple[FloatArray, FloatArray] | None] | None:
        """``(q̇, task state, diagnostics, copies)`` of one step, or None when an input fails
        the kernel's conservative check (NaN, a joint outside its limits, ...): the
        controller then runs the object path, which raises the error that names the input.
        ``copies`` are the copies of ``q`` and ``q̇`` the diagnostics keep when the safety
        layer raised events (read only: the command history may keep them too), or None.

        Args: as :meth:`redservo.control.Controller.step` (``J`` the model Jacobian (6, n)
        when the caller has it; ``de1_dt`` (m,) and ``secondary`` (n,) as the law takes
        them). Units: rad or m, s, normalized image units, 1/m.
        """
        iz = self._inverse_depths(inv_depth)
        if iz is None:
            return None  # the object path checks them
        meas = (s, iz, self.s_star, self.C)
        if qdot_prev is None:
            prev = _EMPTY
        elif qdot_prev.shape == self.shapes[1:2] and qdot_prev.dtype == _F64:
            # The kernel only reads it: a read-only or strided one is copied (the same
            # numbers), as a read-only array is another numba type, for which the whole step
            # chain (22-26 kernels, every law) would be compiled a second time.
            prev = qdot_prev if qdot_prev.flags.carray else np.array(qdot_prev, order="C")
        else:
            return None  # the object path checks it
        if de1_dt is None and secondary is None:
            inputs = (_EMPTY, _EMPTY, prev)
            plain = prev.flags.carray and q.flags.carray and s.flags.carray
        else:
            ff = _EMPTY if de1_dt is None else np.ascontiguousarray(de1_dt, dtype=np.float64)
            sec = _EMPTY if secondary is None else np.ascontiguousarray(secondary, dtype=np.float64)
            inputs, plain = (ff, sec, prev), False
        buf = np.empty(self.size)
        gains = self.gains if self.adaptive is None else self._adapted(s)
        if J is None and self.kernel is not None:
            packs = (meas, self.law_pack, self.limits_pack, gains, inputs, buf)
            lmask, smask, vec = self.run_kernel(q, packs, plain)
        else:
            Jm = np.ascontiguousarray(J if J is not None else self.jacobian(q))
            args = (q, Jm, meas, self.law_pack, self.limits_pack, gains, inputs, buf)
            lmask, smask, vec = self.run_measured(args, plain and iz.flags.carray)
        if lmask < 0:
            return None
        return results(self, q, s, tuple(inv_depth), buf, lmask, smask, vec)

    def run_kernel(
        self, q: FloatArray, packs: tuple[Any, ...], plain: bool = False
    ) -> tuple[int, int, FloatArray]:
        """:attr:`kernel` on ``q`` (n,) and ``packs`` (``meas, law, limits, gains, inputs,
        buf``, module docstring of :mod:`redservo.kernels.control`). ``plain``: the caller's
        arrays (``q``, ``s``, ``qdot_prev``) are float64 (n,), (k,), (n,) or empty, C-contiguous,
        aligned and writeable, and there is no feed-forward or secondary input (the other
        arrays are this binding's own or fresh): the kernel's compiled version for these
        types is then called at its entry point (:mod:`redservo.kernels.entry`; the
        dispatcher's first such call finds it), else through the dispatcher. The same
        machine code either way."""
        entry = self.entry[0]
        if plain and entry:
            return entry(q, self.robot, packs)  # type: ignore[operator]  # truthy: callable
        assert self.kernel is not None  # the caller's condition
        out = self.kernel(q, self.robot, *packs)
        if plain and entry is None:  # looked up once: False when there is none
            self.entry[0] = entry_of(self.kernel, (q, self.robot, packs)) or False
        return out

    def run_measured(self, args: tuple[Any, ...], plain: bool) -> tuple[int, int, FloatArray]:
        """:func:`~redservo.kernels.control.measured_control` on ``args`` (``q, J, meas,
        law, limits, gains, inputs, buf``), at its entry point for this set-up's types
        (:attr:`measured_entry`) when ``plain`` (:meth:`run_kernel`'s condition, the
        inverse depths' array included) and ``J`` is a C-contiguous, aligned, writeable
        float64 (6, n) array, else through the dispatcher: the same machine code."""
        J = args[1]
        plain = plain and J.dtype == _F64 and J.flags.carray
        entry = self.measured_entry[0]
        if plain and entry:
            return entry(*args)  # type: ignore[operator]  # truthy: callable
        kernel = self.measured or _K.measured_control
        out = kernel(*args)
        if plain and entry is None:  # looked up once: False when there is none
            self.measured_entry[0] = entry_of(kernel, args) or False
        return out

    def _adapted(self, s: FloatArray) -> tuple[float, float]:
        """``(λ(‖e1‖∞), dt)`` with ``e1 = C (s − s*)`` computed as the object path does."""
        e = s - self.s_star
        e1 = e if self.C.shape[0] == 0 else self.C @ e
        return gain_value(self.adaptive, e1), self.gains[1]  # type: ignore[arg-type]

    def _inverse_depths(self, inv_depth: Sequence[FloatArray]) -> FloatArray | None:
        """The points' inverse depths (N,) as ``L`` uses them (the task's depth option), or
        None when they are not one number per point."""
        try:
            iz = np.concatenate(inv_depth)
            if any(len(d) != 1 for d in inv_depth):  # N numbers, but not one per point
                return None
        except (ValueError, TypeError):
            return None
        if iz.dtype.kind not in "iuf":  # booleans, objects, complex: the object path refuses
            return None
        if iz.dtype != _F64:
            try:
                iz = iz.astype(np.float64)
            except (ValueError, TypeError):
                return None
        if iz.shape != self.iz_shape:
            return None
        return self.depth_scaled(iz) if self.depth_option else iz

    def depth_scaled(self, iz: FloatArray) -> FloatArray:
        """The points' inverse depths ``iz`` (N,) (1/m) through the task's depth option and
        the depth scale, as ``L`` uses them (a new array, or the task's desired ones: the
        kernel only reads them)."""
        task = self.task
        star = task._group.star  # type: ignore[union-attr]
        return plan.depth_option(iz, star, task.depth, self.depth_scale)


def results(
    eng: CompiledControl,
    q: FloatArray,
    s: FloatArray,
    inv_depth: tuple[FloatArray, ...],
    buf: FloatArray,
    lmask: int,
    smask: int,
    vec: FloatArray,
) -> tuple[FloatArray, TaskState, Diagnostics, tuple[FloatArray, FloatArray] | None]:
    """``(q̇, task state, diagnostics, copies)`` of ``eng``'s step: views of the kernel's
    buffer as the object path's results; the diagnostics are built when first read
    (:class:`~redservo.redundancy.base.LazyDiagnostics`) from the law part of the buffer
    (``qdot`` to ``ssrc``), the law's options as bound (:attr:`CompiledControl.law_state`), and ``copies`` of ``q`` and
    ``q̇`` when the safety layer raised events (else None)."""
    sq, se, se1, sJ1, sL = eng.task_slices
    qdot, e = buf[sq], buf[se]
    m, n, k = eng.shapes
    e1 = e if eng.no_C else buf[se1]
    state = _new_state(
        TaskState, (s, e, e1, buf[sL].reshape(k, 6), buf[sJ1].reshape(m, n), inv_depth)
    )
    law = eng.law
    if smask:
        copies: tuple[FloatArray, FloatArray] | None = (q.copy(), qdot.copy())
        safety = (*copies, eng.gains[1], eng.limits)  # type: ignore[misc]
    else:
        copies = safety = None
    args = (type(law), eng.law_state, m, buf, eng.law_slices, (lmask, smask, vec), safety)
    diag = _new_lazy(LazyDiagnostics)  # lazy_diagnostics(diagnose, *args) without its calls
    _set(diag, "_build", (diagnose, args))
    return qdot, state, diag, copies


def _reason(robot: Robot, task: VisualTask, law: object, lam: object) -> str:
    """Why this set-up has no compiled engine (one line), or ``""``."""
    from redservo.features import PointFeature

    why = law_reason(law, robot.n)
    if why:
        return why
    if not isinstance(lam, AdaptiveGain) and (
        isinstance(lam, bool) or not isinstance(lam, int | float)
    ):
        return f"gain {lam!r} is neither a number nor an AdaptiveGain"
    if task._group is None or not all(isinstance(t.feature, PointFeature) for t in task.terms):
        return "only tasks of image points are compiled for the controller"
    return ""


def bind_controller(
    robot: Robot,
    task: VisualTask,
    law: object,
    limits: JointLimits,
    *,
    lam: object,
    dt: float,
    depth_scale: float,
) -> CompiledControl | str:
    """The compiled engine of this set-up, or the reason (one line) it has none."""
    why = _reason(robot, task, law, lam)
    if why or not isinstance(law, Law):
        return why
    law_pack = control_pack(law, robot.n)  # kept on the law until an option changes
    pack = robot.kernel_pack()  # None: the Jacobian from the robot object, the rest compiled
    robot_args = () if pack is None else pack
    on_robot, measured = control_kernels(law)
    kernel: Callable[..., Any] | None = None if pack is None else on_robot
    lp = limits_pack(limits)
    C = _NO_C if task.C is None else np.ascontiguousarray(task.C, dtype=np.float64)
    m = task.k if task.C is None else C.shape[0]
    layout = _K.control_layout(robot.n, m, task.k)
    size = layout.pop("size")[1]
    return CompiledControl(
        kernel=kernel,
        robot=robot_args,
        jacobian=lambda q: robot.jacobian(q, check_limits=False),
        law_pack=law_pack,
        limits_pack=(lp.rows, lp.has_v, lp.has_a),
        s_star=np.ascontiguousarray(task.s_star, dtype=np.float64),
        C=C,
        law=law,
        limits=limits,
        task=task,
        gains=(np.nan if isinstance(lam, AdaptiveGain) else float(cast(float, lam)), float(dt)),
        adaptive=lam if isinstance(lam, AdaptiveGain) else None,
        depth_scale=float(depth_scale),
        law_slices=tuple(slice(*layout[k]) for k in LAW_PARTS),
        task_slices=tuple(slice(*layout[k]) for k in ("qdot", "e", "e1", "J1", "L")),
        q_part=slice(*layout["q"]),
        size=size,
        spare=[np.empty(size)],
        shapes=(m, robot.n, task.k),
        q_shape=(robot.n,),
        s_shape=(task.k,),
        iz_shape=(len(task.terms),),
        iz_buffer=(iz := np.zeros(len(task.terms))),
        iz_rows=iz.reshape(-1, 1),
        iz_bytes=memoryview(iz).cast("B"),  # type: ignore[arg-type]  # an ndarray is a buffer
        depth_option=task.depth != "current" or float(depth_scale) != 1.0,
        no_C=task.C is None,
        law_token=law.__dict__.get(_PACK),
        law_state=dict(law.__dict__),
        measured=measured,
    )
