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

_KC = lazy("control")
_KS = lazy("step")
_EMPTY = np.zeros(0)
_IDS: dict[type, int] = {}


def kernel_id(cls: type) -> int:
    """The id of the law kernel of ``cls``: the kernel of its nearest shipped ancestor (a
    class of :mod:`redservo.redundancy` whose ``name`` has a compiled step), or -1."""
    hit = _IDS.get(cls)
    if hit is None:
        from redservo.kernels.step import LAW_IDS

        hit = -1
        for k in cls.__mro__:
            name = k.__dict__.get("name")
            if k.__module__.startswith("redservo.redundancy.") and name in LAW_IDS:
                hit = LAW_IDS[name]
                break
        _IDS[cls] = hit
    return hit


def _given(x: FloatArray | None) -> FloatArray:
    return _EMPTY if x is None else np.ascontiguousarray(x, dtype=np.float64)


def _packs(law: Law, x: LawInputs) -> tuple[Any, ...]:
    """``(J1, e1, q, law pack, limits pack, gains, inputs)`` of a law kernel call."""
    J1 = np.ascontiguousarray(x.J1)
    o: LawOptions = pack_options(law, J1.shape[1], kernel_id(type(law)))
    lp = limits_pack(x.limits)
    inputs = (_given(x.de1_dt), _given(x.secondary), _given(x.qdot_prev), _EMPTY)
    law_pack = (o.law_id, o.fopt, o.iopt, o.vopt)
    limits = (lp.rows, lp.has_v, lp.has_a)
    return J1, np.ascontiguousarray(x.e1), np.ascontiguousarray(x.q), law_pack, limits, inputs


def kernel_call(law: Law, x: LawInputs) -> tuple[FloatArray, Diagnostics] | None:
    """``(q̇, diagnostics)``: the law's safe command for the validated inputs ``x`` through
    the step kernel, or None when an input fails the kernel's conservative check (finite and
    below 1e300; the caller then runs :meth:`~redservo.redundancy.Law.compute` and the safety
    layer of :mod:`redservo.redundancy.safety`)."""
    J1, e1, q, law_pack, limits, inputs = _packs(law, x)
    gains = (x.lam, x.dt)
    ok, out, lev, sev = _KC.law_core(q, J1, e1, law_pack, limits, gains, inputs)
    if not ok:
        return None
    qdot, iout, fout, axes, axf, vec, sout = out
    smask, svals, ssrc = sev
    more: tuple[Event, ...] = ()
    if smask:
        more = safety_events(
            smask, svals, ssrc, q, qdot, x.dt, x.limits, float(sout[6]), int(sout[10])
        )
    lo = LawOutputs(iout, fout, axes, axf, vec, *lev)
    return qdot, law.diagnose(J1.shape[0], lo, more)  # type: ignore[attr-defined]


def kernel_compute(law: Law, x: LawInputs) -> tuple[FloatArray, Diagnostics]:
    """``(q̇, diagnostics)``: the law's raw command, before the safety layer
    (:meth:`~redservo.redundancy.Law.compute`), from the law kernel of the step kernel
    (:func:`redservo.kernels.step.law_raw`)."""
    J1, e1, q, law_pack, limits, inputs = _packs(law, x)
    out = _KS.law_raw(law_pack, limits, (x.lam, x.dt), J1, e1, q, inputs)
    return out[0], law.diagnose(J1.shape[0], LawOutputs(*out[1:]))  # type: ignore[attr-defined]
