"""A law's call through the step kernel: validated inputs → packs → the same law kernel.

:meth:`redservo.redundancy.Law.__call__` hands its validated inputs to :func:`kernel_call`
for every shipped law with a compiled step (:data:`redservo.kernels.step.LAW_IDS`) and a
``diagnose`` method, with uniform scaling: the law and its safety layer run in
:func:`redservo.kernels.control.law_core`, the very kernel that the
:class:`~redservo.control.Controller` and the campaign loop drive, and the law's own
``diagnose`` turns the kernel's outputs into its :class:`~redservo.Diagnostics`, as the
Controller does. There is no second composition of law and safety layer for the object
path. :func:`kernel_compute` is such a law's ``compute`` (its raw command, for
secondary-first scaling): the same law kernel without the safety layer
(:func:`redservo.kernels.step.law_raw`). Units: as the law call's (rad or m, s, 1/s).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.packs import limits_pack
from redservo.redundancy.flags import Event
from redservo.redundancy.kio import LawOptions, LawOutputs, pack_options
from redservo.redundancy.safety import safety_events

if TYPE_CHECKING:
    from redservo.redundancy.base import Diagnostics, Law, LawInputs

__all__ = ["kernel_call", "kernel_compute", "kernel_id"]

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import control as _KC
    from redservo.kernels import step as _KS
else:
    _KC = lazy("control")
    _KS = lazy("step")
_EMPTY = np.zeros(0)
_IDS: dict[type, int] = {}
_SLICES: dict[int, tuple[int, tuple[slice, ...]]] = {}
_PARTS = ("qdot", "iout", "fout", "sout", "axes", "axf", "lvals", "lsrc", "svals", "ssrc")
_PACK = "_kernel_pack"
"""Where a law keeps its packed options (:func:`_law_pack`)."""


def kernel_id(cls: type) -> int:
    """The id of the law kernel of ``cls``: the kernel of its nearest ancestor declaring one
    (``KERNEL``, :mod:`redservo.redundancy.declare`) whose ``name`` has a compiled step, or -1."""
    hit = _IDS.get(cls)
    if hit is None:
        from redservo.kernels.step import LAW_IDS

        hit = -1
        for k in cls.__mro__:
            name = k.__dict__.get("name")
            if "KERNEL" in k.__dict__ and name in LAW_IDS:
                hit = LAW_IDS[name]
                break
        _IDS[cls] = hit
    return hit


def _given(x: FloatArray | None) -> FloatArray:
    return _EMPTY if x is None else np.ascontiguousarray(x, dtype=np.float64)


def _law_pack(law: Law, n: int) -> tuple[Any, ...]:
    """The law's options packed for ``n`` joints, kept on the law until one of its public
    attributes is set (:meth:`redservo.redundancy.Law.__setattr__` drops it)."""
    hit = law.__dict__.get(_PACK)
    if hit is not None and hit[0] == n:
        return hit[1]
    o: LawOptions = pack_options(law, n, kernel_id(type(law)))
    pack = (o.law_id, o.fopt, o.iopt, o.vopt)
    law.__dict__[_PACK] = (n, pack)
    return pack


def _packs(law: Law, x: LawInputs) -> tuple[Any, ...]:
    """``(J1, e1, q, law pack, limits pack, inputs)`` of a law kernel call."""
    J1 = np.ascontiguousarray(x.J1)
    lp = limits_pack(x.limits)
    inputs = (_given(x.de1_dt), _given(x.secondary), _given(x.qdot_prev), _EMPTY)
    limits = (lp.rows, lp.has_v, lp.has_a)
    law_pack = _law_pack(law, J1.shape[1])
    return J1, np.ascontiguousarray(x.e1), np.ascontiguousarray(x.q), law_pack, limits, inputs


def _slices(n: int) -> tuple[int, tuple[slice, ...]]:
    """The size and the parts ``qdot`` to ``ssrc`` of a law call's buffer for ``n`` joints
    (:func:`redservo.kernels.control.control_layout`)."""
    hit = _SLICES.get(n)
    if hit is None:
        layout = _KC.control_layout(n, 0, 0)
        parts = [layout[k] for k in _PARTS]
        hit = _SLICES[n] = (parts[-1][1], tuple(slice(*p) for p in parts))
    return hit


def kernel_call(law: Law, x: LawInputs) -> tuple[FloatArray, Diagnostics] | None:
    """``(q̇, diagnostics)``: the law's safe command for the validated inputs ``x`` through
    the step kernel, or None when an input fails the kernel's conservative check (finite and
    below 1e300; the caller then runs :meth:`~redservo.redundancy.Law.compute` and the safety
    layer of :mod:`redservo.redundancy.safety`)."""
    J1, e1, q, law_pack, limits, inputs = _packs(law, x)
    size, parts = _slices(q.shape[0])
    buf = np.empty(size)
    lmask, smask, vec = _KC.law_into(q, J1, e1, law_pack, limits, (x.lam, x.dt), inputs, buf)
    if lmask < 0:
        return None
    qdot, iout, fout, sout, axes, axf, lvals, lsrc, svals, ssrc = (buf[p] for p in parts)
    more: tuple[Event, ...] = ()
    if smask:
        more = safety_events(
            smask,
            svals,
            ssrc.astype(np.int64),
            q,
            qdot,
            x.dt,
            x.limits,
            float(sout[6]),
            int(sout[10]),
        )
    lo = LawOutputs(iout.astype(np.int64), fout, axes, axf, vec, lmask, lvals, lsrc)
    return qdot, law.diagnose(J1.shape[0], lo, more)  # type: ignore[attr-defined]


def kernel_compute(law: Law, x: LawInputs) -> tuple[FloatArray, Diagnostics]:
    """``(q̇, diagnostics)``: the law's raw command, before the safety layer
    (:meth:`~redservo.redundancy.Law.compute`), from the law kernel of the step kernel
    (:func:`redservo.kernels.step.law_raw`)."""
    J1, e1, q, law_pack, limits, inputs = _packs(law, x)
    out = _KS.law_raw(law_pack, limits, (x.lam, x.dt), J1, e1, q, inputs)
    return out[0], law.diagnose(J1.shape[0], LawOutputs(*out[1:]))  # type: ignore[attr-defined]
