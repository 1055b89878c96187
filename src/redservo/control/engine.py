"""The compiled engine of a :class:`~redservo.control.Controller`: which engine its step
runs on (module docstring of :mod:`redservo.control.controller`, "Engines") and the step in
one compiled call."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any, Generic, TypeVar, overload

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, is_float_vector
from redservo.binding.control import CompiledControl, bind_controller, stale
from redservo.binding.depths import take_inverse_depths
from redservo.control.kernel_step import KernelStep
from redservo.control.output import shape_output
from redservo.control.steps import ControlStep, Features, SceneContext
from redservo.errors import ConfigurationError
from redservo.records.lazy import _set_src
from redservo.redundancy.kernel_call import _PACK

if TYPE_CHECKING:
    from redservo.control.controller import Controller

__all__ = [
    "QuickSetting",
    "bind_engine",
    "compiled_step",
    "python_parts",
    "quick_ok",
    "quick_step",
    "setup_engine",
]

_EMPTY = np.zeros(0)
_NO_INPUTS = (_EMPTY, _EMPTY, _EMPTY)
"""No feed-forward, secondary command or previous command (the kernel only reads them)."""
_empty = np.empty
_refs = sys.getrefcount
T = TypeVar("T")
_new = object.__new__
_F64 = np.dtype(np.float64)
_ND = np.ndarray


def bind_engine(ctrl: Controller, engine: str) -> tuple[CompiledControl | None, str]:
    """The compiled engine of ``ctrl`` and ``""``, or None and the reason (one line) it is
    not used. ``engine``: ``"auto"``, ``"compiled"`` (an error when there is none) or
    ``"python"`` (the object path).

    Raises:
        ConfigurationError: ``engine`` is unknown, or ``"compiled"`` without a compiled
            engine for this set-up (``argument="engine"``, the reason in the message).
    """
    if engine not in ("auto", "compiled", "python"):
        raise ConfigurationError(
            f"engine must be 'auto', 'compiled' or 'python', got {engine!r}", argument="engine"
        )
    if engine == "python":
        return None, "engine='python' asked for"
    why = ""
    if ctrl.objectives:
        why = "objectives need the task state before the law"
    elif ctrl.feedforward == "estimated":
        why = "the estimated feed-forward needs the task state before the law"
    bound = why or bind_controller(
        ctrl.robot,
        ctrl.task,
        ctrl.law,
        ctrl.limits,
        lam=ctrl.lam,
        dt=ctrl.dt,
        depth_scale=ctrl.depth_scale,
    )
    if isinstance(bound, str):
        if engine == "compiled":
            raise ConfigurationError(f"no compiled engine: {bound}", argument="engine")
        return None, bound
    return bound, ""


def python_parts(ctrl: Controller) -> list[str]:
    """The parts of ``ctrl``'s step written in Python by a user (a law that is not a
    registered method, a task overriding its evaluation, an objective from outside
    redservo or a plain function): empty for the shipped parts, which are compiled kernels."""
    from redservo.control.objectives import CallableObjective
    from redservo.redundancy.base import Law, registered_methods

    parts = []
    law = ctrl.law
    if not isinstance(law, Law) or type(law) is not registered_methods().get(law.name):
        name = getattr(law, "name", None) or getattr(law, "__name__", type(law).__name__)
        parts.append(f"law {name!r}")
    if ctrl.task._custom:
        parts.append(f"task {type(ctrl.task).__name__}")
    parts += [
        f"objective {type(o).__name__}"
        for o in ctrl.objectives
        if isinstance(o, CallableObjective) or type(o).__module__.split(".")[0] != "redservo"
    ]
    return parts


def setup_engine(ctrl: Controller, engine: str) -> tuple[CompiledControl | None, list[str], str]:
    """``(compiled engine or None, the parts written in Python, why not compiled)`` of
    ``ctrl`` (:func:`bind_engine`, :func:`python_parts`; the reason ``""`` when compiled).

    Raises:
        ConfigurationError: as :func:`bind_engine`.
    """
    compiled, why = bind_engine(ctrl, engine)
    python = python_parts(ctrl)
    return compiled, python, ("written in Python: " + ", ".join(python) if python else why)


def compiled_step(
    ctrl: Controller,
    q: FloatArray,
    measurement: Features,
    t: float,
    qdot_prev: ArrayLike | None,
    J: ArrayLike | None,
    context: SceneContext | None,
) -> ControlStep | None:
    """:meth:`Controller.step <redservo.control.Controller.step>` in one compiled call, its
    command recorded in the controller's history, or None to take the object path (an input
    the kernel's check rejects: the object path raises the error naming it). Units: as the
    step's (rad or m, s)."""
    if stale(ctrl._compiled):  # type: ignore[arg-type]  # the caller's test
        ctrl.rebind()
    compiled = ctrl._compiled
    if compiled is None:  # the law's new options have no compiled step
        return None
    ctrl.stage = "task"
    s = getattr(measurement, "s", None)
    if not is_float_vector(s, compiled.shapes[2]):  # the kernel checks the values, this the rest
        s = ctrl._measured_s(measurement)
    Ja = None if J is None else ctrl.jacobian(q, J)
    ctrl.stage = "feed-forward"
    prev = None if qdot_prev is None else np.asarray(qdot_prev, dtype=float)
    de1_dt = ctrl._feedforward_known(t, context) if ctrl.feedforward == "known" else None
    ctrl.stage = "law"
    iz = getattr(measurement, "inv_depth", None)  # checked by the kernel's binding
    res = compiled.step(q, s, iz, prev, J=Ja, de1_dt=de1_dt)  # type: ignore[arg-type]
    if res is None:
        return None
    qdot, state, diag, copies = res
    if ctrl.qdot_saturation is None and ctrl.image_motion is None and ctrl.collision is None:
        ctrl.stage = "guard"  # the output stage has nothing to do (shape_output's no-op)
        saturated = False
        if copies is not None:  # the diagnostics' copies of q and q̇ serve the history too
            ctrl.history.keep(t, *copies)
        else:
            ctrl.history.record(t, q, qdot)
    else:
        qdot, diag, saturated = shape_output(ctrl, qdot, diag, state, q, Ja, t, prev)
        ctrl.history.record(t, q, qdot)
    return ControlStep(qdot, state, diag, None, de1_dt, None, saturated)


def quick_step(
    ctrl: Controller, q: Any, measurement: Any, t: Any, qdot_prev: Any
) -> ControlStep | None:
    """:func:`compiled_step` for the step a loop repeats, as one Python function around the
    kernel's entry point (:mod:`redservo.kernels.entry`), or None to take
    :meth:`Controller.step <redservo.control.Controller.step>`'s full path.

    It runs when nothing needs more than the kernel: a finite float ``t`` (s), no
    measurement ``stamp`` to bring to the present, ``q`` (n,), ``measurement.s`` (k,) and
    ``qdot_prev`` (n,) (or None) float64 arrays the entry takes as they are (C-contiguous,
    aligned, writeable), N inverse depths of one number each
    (:func:`~redservo.binding.depths.take_inverse_depths`), no
    feed-forward, output saturation, camera-motion limit or distance shield set
    (:class:`QuickSetting`) and the law's options those the engine bound (read at every
    step: a set-up changed since takes the full path). An input the kernel's check rejects
    returns None before any state changed, so the full path then checks it and raises the
    one error naming it. The command, task state, diagnostics and history are those of the
    full path bit for bit (the same kernel, the same buffer layout), made when first read
    (:class:`~redservo.control.kernel_step.KernelStep`). Units: as the step's (rad or m, s).
    """
    eng: CompiledControl = ctrl._compiled  # type: ignore[assignment]  # the caller's test
    entry = eng.entry[0]
    if not entry or type(t) is not float or t - t != 0.0:  # inf - inf and nan - nan: nan
        return None
    robot, s_star, C, law_pack, limits_pack, gains, size, q_shape, s_shape, part, law, token = (
        eng.hot
    )
    if (
        not ctrl._plain_setup
        or (ctrl.compensate_latency and getattr(measurement, "stamp", None) is not None)
        or law.get(_PACK) is not token  # stale(eng), without the call
    ):
        return None
    s = getattr(measurement, "s", None)
    if not (
        type(q) is _ND
        and type(s) is _ND
        and q.shape == q_shape
        and s.shape == s_shape
        and q.dtype is _F64  # numpy's own float64 (another equal dtype: the full path)
        and s.dtype is _F64
        and q.flags.carray
        and s.flags.carray
    ):
        return None
    if qdot_prev is None:
        given = _NO_INPUTS
    elif (
        type(qdot_prev) is _ND
        and qdot_prev.shape == q_shape
        and qdot_prev.dtype is _F64
        and qdot_prev.flags.carray
    ):
        given = (_EMPTY, _EMPTY, qdot_prev)
    else:
        return None
    inv_depth: Any = getattr(measurement, "inv_depth", None)
    if not take_inverse_depths(eng, inv_depth):  # N >= 2 (quick_ok): not a number per point
        return None
    iz = eng.depth_scaled(eng.iz_buffer) if eng.depth_option else eng.iz_buffer
    spare = eng.spare
    buf = spare[0]  # the last step's buffer, warm in the caches: reused when no one holds it
    if _refs(buf) != 3:  # held by more than ``spare``, ``buf`` and this call's argument
        buf = spare[0] = _empty(size)
    ctrl.stage = "law"
    packs = ((s, iz, s_star, C), law_pack, limits_pack, gains, given, buf)
    masks = entry(q, robot, packs)  # type: ignore[operator]  # truthy: callable
    if masks[0] < 0:
        return None
    ctrl.stage = "guard"
    ctrl.history.keep(t, q, buf, part, True)  # q and the command into the ring's slot only
    step: KernelStep = _new(KernelStep)  # KernelStep._lazy(...) without the call
    _set_src(step, (eng, buf, s, tuple(inv_depth), masks))  # buf holds the kernel's copy of q
    return step


class QuickSetting(Generic[T]):
    """A :class:`~redservo.control.Controller` option that :func:`quick_step` reads as one
    flag: setting it (at construction or later) sets ``ctrl._plain_setup``, True when no
    output saturation, camera-motion limit, distance shield or feed-forward is set."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.key = "_setting_" + name

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> QuickSetting[T]: ...

    @overload
    def __get__(self, obj: object, owner: type | None = None) -> T: ...

    def __get__(self, obj: object, owner: type | None = None) -> T | QuickSetting[T]:
        return self if obj is None else obj.__dict__[self.key]

    def __set__(self, obj: object, value: T) -> None:
        d = obj.__dict__
        d[self.key] = value
        d["_plain_setup"] = (
            d.get("_setting_qdot_saturation") is None
            and d.get("_setting_image_motion") is None
            and d.get("_setting_collision") is None
            and d.get("_setting_feedforward", "none") == "none"
        )


def quick_ok(eng: CompiledControl | None) -> bool:
    """A controller with the compiled engine ``eng`` may try :func:`quick_step` first: the
    robot's kinematics compiled, a fixed gain, at least two points (so that a bare number
    per point cannot pass for an (N, 1) block of inverse depths)."""
    return (
        eng is not None and eng.kernel is not None and eng.adaptive is None and eng.iz_shape[0] >= 2
    )
