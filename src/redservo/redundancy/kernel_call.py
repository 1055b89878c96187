"""A law's call through the step kernel: validated inputs → packs → the same law kernel.

:meth:`redservo.redundancy.Law.__call__` hands its inputs to :func:`quick` (the signature
of the law's previous call: one look at the inputs' types, shapes and layouts, then the
kernel's entry point), to :func:`fast_call` (inputs with the signature the kernel takes:
the kernel alone checks their values) or, after the full checks, to :func:`kernel_call`, for every shipped law with a compiled step (:data:`redservo.kernels.step.LAW_IDS`) and a
``diagnose`` method, with uniform scaling: the law and its safety layer run in
:func:`redservo.kernels.control.law_core`, the very kernel that the
:class:`~redservo.control.Controller` and the campaign loop drive, and the law's own
``diagnose`` turns the kernel's outputs into its :class:`~redservo.Diagnostics` when they
are first read (:func:`diagnose`, :class:`~redservo.redundancy.base.LazyDiagnostics`), as
the Controller does. There is no second composition of law and safety layer for the object
path. :func:`kernel_compute` is such a law's ``compute`` (its raw command, for
secondary-first scaling): the same law kernel without the safety layer
(:func:`redservo.kernels.step.law_raw`). Units: as the law call's (rad or m, s, 1/s).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.kernels.entry import Spares, entry_of
from redservo.limits import JointLimits
from redservo.redundancy.flags import Event
from redservo.redundancy.gain import AdaptiveGain, gain_value
from redservo.redundancy.inputs import _array
from redservo.redundancy.kio import LawOptions, LawOutputs, pack_options
from redservo.redundancy.packs import limits_pack
from redservo.redundancy.safety import safety_events

if TYPE_CHECKING:
    from redservo.redundancy.base import Diagnostics, Law, LawInputs

__all__ = [
    "LAW_PARTS",
    "DiagnoseArgs",
    "diagnose",
    "fast_call",
    "kernel_call",
    "kernel_compute",
    "kernel_id",
    "quick",
]

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import control as _KC
    from redservo.kernels import step as _KS
else:
    _KC = lazy("control")
    _KS = lazy("step")
_EMPTY = np.zeros(0)
_IDS: dict[type, int] = {}
_SLICES: dict[int, tuple[int, tuple[slice, ...]]] = {}
LAW_PARTS = ("qdot", "iout", "fout", "sout", "axes", "axf", "lvals", "lsrc", "svals", "ssrc")
_PACK = "_kernel_pack"
"""Where a law keeps its packed options (:func:`_law_pack`)."""
_BOUND = "_kernel_bound"
"""Where a law keeps its packs with the limits they were made for (:func:`_bound`)."""
_SEEN = "_kernel_seen"
"""Where a law keeps the signature of its last plain call (:class:`Seen`)."""
_F64 = np.dtype(np.float64)
_NO_INPUTS = (_EMPTY, _EMPTY, _EMPTY, _EMPTY)
"""No feed-forward, secondary command, previous command or history."""


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
    return _EMPTY if x is None else _kernel_array(np.ascontiguousarray(x, dtype=np.float64))


def _kernel_array(a: FloatArray) -> FloatArray:
    """``a`` with the one array type the warmed kernels take (C-contiguous, aligned and
    writeable float64): a copy, the same values, when it is read-only or misaligned (numba
    types those apart: a read-only ``qdot_prev`` compiled the whole law chain again)."""
    return a if a.flags.carray else np.array(a, dtype=np.float64, order="C")


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
    J1 = _kernel_array(np.ascontiguousarray(x.J1))
    lp = limits_pack(x.limits)
    inputs = (_given(x.de1_dt), _given(x.secondary), _given(x.qdot_prev), _EMPTY)
    limits = (lp.rows, lp.has_v, lp.has_a)
    law_pack = _law_pack(law, J1.shape[1])
    e1, q = (_kernel_array(np.ascontiguousarray(a)) for a in (x.e1, x.q))
    return J1, e1, q, law_pack, limits, inputs


Masks = tuple[int, int, FloatArray | int]
"""``(law mask, safety mask, vec)`` of a law kernel call (what :func:`diagnose` reads), or
with ``vec``'s length in its place when it is in the buffer after the law's parts."""


def _slices(n: int) -> tuple[int, tuple[slice, ...]]:
    """The size and the parts ``qdot`` to ``ssrc`` of a law call's buffer for ``n`` joints
    (:func:`redservo.kernels.control.control_layout`), with room for the law's ``vec``
    after them: n (n + 1) entries, the most a law writes (the iterative family's gains of at
    most n levels on at most n null-space directions, and a flag per level)."""
    hit = _SLICES.get(n)
    if hit is None:
        layout = _KC.control_layout(n, 0, 0)
        parts = [layout[k] for k in LAW_PARTS]
        hit = _SLICES[n] = (parts[-1][1] + n * (n + 1), tuple(slice(*p) for p in parts))
    return hit


def diagnose(
    cls: type[Law],
    state: dict[str, Any],
    m: int,
    buf: FloatArray,
    parts: tuple[slice, ...],
    masks: Masks,
    safety: tuple[FloatArray, FloatArray, float, JointLimits] | None,
) -> Diagnostics:
    """The law's :class:`~redservo.Diagnostics` from a law kernel call's buffer ``buf``
    (its ``parts``), ``masks`` (:data:`Masks`) and, when the safety layer
    raised events, ``(q, q̇, dt, limits)``; the law is rebuilt from its class and attribute
    dictionary ``state`` as it was at the call (so a later change of an option does not
    change what the diagnostics say)."""
    law = object.__new__(cls)
    law.__dict__.update(state)
    _, iout, fout, sout, axes, axf, lvals, lsrc, svals, ssrc = (buf[p] for p in parts)
    lmask, smask, given = masks
    if isinstance(given, int):  # its length: the law kernel wrote it after the parts (law_into)
        vec = buf[parts[-1].stop : parts[-1].stop + given]
    else:
        vec = given
    more: tuple[Event, ...] = ()
    if smask and safety is not None:
        q, qdot, dt, limits = safety
        more = safety_events(
            smask, svals, ssrc.astype(np.int64), q, qdot, dt, limits, float(sout[6]), int(sout[10])
        )
    lo = LawOutputs(iout.astype(np.int64), fout, axes, axf, vec, lmask, lvals, lsrc)
    return law.diagnose(m, lo, more)  # type: ignore[attr-defined]


DiagnoseArgs = tuple[Any, ...]
"""The arguments of :func:`diagnose` for one call (what its lazy diagnostics keep)."""


def _run(
    law: Law,
    arrays: tuple[FloatArray, FloatArray, FloatArray],
    limits: JointLimits,
    packs: tuple[Any, Any, tuple[float, float], tuple[FloatArray, ...]],
) -> tuple[FloatArray, DiagnoseArgs] | None:
    """The law kernel call on checked arrays ``(J1, e1, q)`` and ``packs`` ``(law pack,
    limits pack, (λ, dt), inputs)``: ``(q̇, the arguments of diagnose)``, with copies of
    what the caller may change afterwards, or None when the kernel's input check fails."""
    J1, e1, q = arrays
    law_pack, limits_t, gains, inputs = packs
    return _into(law, (J1, e1, q), limits, (law_pack, limits_t), gains, inputs, _slices(q.shape[0]))


def _into(
    law: Law,
    arrays: tuple[FloatArray, FloatArray, FloatArray],
    limits: JointLimits,
    bound: tuple[Any, Any],
    gains: tuple[float, float],
    inputs: tuple[FloatArray, ...],
    layout: tuple[int, tuple[slice, ...]],
    entry: list[Any] | None = None,
) -> tuple[FloatArray, DiagnoseArgs] | None:
    """:func:`_run` with the packs ``bound`` ``(law pack, limits pack)`` and the buffer
    ``layout`` ``(size, parts)`` already found (the hot path). ``entry``: when the arrays are
    those of the signature kept on the law (:func:`fast_call`: C-contiguous, aligned,
    writeable float64), its slot for the kernel's entry point (:mod:`redservo.kernels.entry`),
    found by the first such call and then called directly: the same machine code."""
    J1, e1, q = (_kernel_array(a) for a in arrays)
    law_pack, limits_t = bound
    size, parts = layout
    buf = np.empty(size)
    args = (q, J1, e1, law_pack, limits_t, gains, inputs, buf)
    if entry is not None and entry[0]:
        out = entry[0](*args)
    else:
        out = _KC.law_into(*args)
        if entry is not None and entry[0] is None:  # looked up once: False when there is none
            entry[0] = entry_of(_KC.law_into, args) or False
    if out[0] < 0 or out[2] < 0:
        return None
    qdot = buf[parts[0]]
    safety = (q.copy(), qdot.copy(), gains[1], limits) if out[1] else None
    masks = out  # vec by its length (diagnose reads it from the buffer)
    return qdot, (type(law), dict(law.__dict__), J1.shape[0], buf, parts, masks, safety)


def kernel_call(law: Law, x: LawInputs) -> tuple[FloatArray, DiagnoseArgs] | None:
    """``(q̇, the arguments of diagnose)``: the law's safe command for the validated inputs
    ``x`` through the step kernel, or None when an input fails the kernel's conservative
    check (finite and below 1e300; the caller then runs
    :meth:`~redservo.redundancy.Law.compute` and the safety layer of
    :mod:`redservo.redundancy.safety`). The caller builds the diagnostics when they are read
    (:func:`~redservo.redundancy.base.lazy_diagnostics` with :func:`diagnose`)."""
    J1, e1, q, law_pack, limits, inputs = _packs(law, x)
    return _run(law, (J1, e1, q), x.limits, (law_pack, limits, (x.lam, x.dt), inputs))


def kernel_compute(law: Law, x: LawInputs) -> tuple[FloatArray, Diagnostics]:
    """``(q̇, diagnostics)``: the law's raw command, before the safety layer
    (:meth:`~redservo.redundancy.Law.compute`), from the law kernel of the step kernel
    (:func:`redservo.kernels.step.law_raw`)."""
    J1, e1, q, law_pack, limits, inputs = _packs(law, x)
    out = _KS.law_raw(law_pack, limits, (x.lam, x.dt), J1, e1, q, inputs)
    return out[0], law.diagnose(J1.shape[0], LawOutputs(*out[1:]))  # type: ignore[attr-defined]


def _bound(law: Law, limits: object, n: int) -> tuple[Any, Any] | None:
    """``(law pack, limits pack)`` for ``n`` joints, packed once and kept on the law with the
    limits they were made for; None when ``limits`` is not a JointLimits of ``n`` joints."""
    hit = law.__dict__.get(_BOUND)
    pack = _law_pack(law, n)
    if hit is not None and hit[0] is limits and hit[1] is pack:
        return pack, hit[2]
    if type(limits) is not JointLimits or limits.n != n:
        return None
    lp = limits_pack(limits)
    limits_t = (lp.rows, lp.has_v, lp.has_a)
    law.__dict__[_BOUND] = (limits, pack, limits_t)
    return pack, limits_t


class Seen:
    """The signature of a law's last plain call (:func:`fast_call`), kept on the law
    (:data:`_SEEN`): what :func:`quick` compares a call with, and what it then reuses."""

    __slots__ = ("bound", "entry", "layout", "limits", "m", "mn", "n", "pack", "spares", "state")

    def __init__(self, law: Law, limits: JointLimits, mn: tuple[int, int], bound: Any) -> None:
        self.limits, self.pack, self.bound = limits, law.__dict__[_PACK], bound
        self.mn, self.m, self.n = mn, (mn[0],), (mn[1],)
        self.layout = _slices(mn[1])
        self.spares = Spares(((self.layout[0],),))
        """The kernel's buffers: one no result holds any more is written again (a loop's
        calls alternate between two, warm in the caches; :class:`~redservo.kernels.entry.Spares`)."""
        self.entry: list[Any] = [None]  # the kernel's entry point, found by the first plain call
        self.state = dict(law.__dict__)
        """The law's attribute dictionary as the diagnostics read it: a public attribute
        set since drops the pack (:meth:`redservo.redundancy.Law.__setattr__`), so a law
        whose options changed no longer matches ``pack`` and is seen anew."""

    def __reduce__(self) -> tuple[Any, ...]:
        """A pickled or copied law forgets its signature (the kernel's entry point is not
        picklable): its next call is a first call again."""
        return (_forgotten, ())


def _forgotten() -> None:
    """What a pickled :class:`Seen` or :class:`~redservo.features.compiled_points.Hot`
    becomes."""
    return None


def quick(
    law: Law,
    J1: object,
    e1: object,
    q: object,
    limits: object,
    lam: object,
    dt: object,
    qdot_prev: object,
) -> tuple[FloatArray, DiagnoseArgs] | bool | None:
    """``law(J1=..., e1=..., q=..., limits=..., lam=..., dt=..., qdot_prev=...)`` (no
    ``de1_dt``, no ``secondary``) when the call has the signature of the law's last plain
    call (:class:`Seen`): the same limits object and packed options, float64 arrays of the
    same shapes, C-contiguous, aligned and writeable, and float gains ``0 < λ, dt < ∞``
    (1/s, s). One look at each input's metadata, then the kernel at its entry point (its own
    ``inputs_ok`` checks the values). Returns ``(q̇, the arguments of diagnose)``, False
    when the kernel refused a value (the caller then validates in full, which names it), or
    None when the signature differs (the caller then takes :func:`fast_call`)."""
    state = law.__dict__
    seen: Seen | None = state.get(_SEEN)
    if (
        seen is None
        or limits is not seen.limits
        or seen.pack is not state.get(_PACK)
        or type(J1) is not np.ndarray
        or type(e1) is not np.ndarray
        or type(q) is not np.ndarray
        or type(lam) is not float
        or type(dt) is not float
        or J1.shape != seen.mn
        or e1.shape != seen.m
        or q.shape != seen.n
        or J1.dtype != _F64
        or e1.dtype != _F64
        or q.dtype != _F64
        or not (J1.flags.carray and e1.flags.carray and q.flags.carray)
        or not (0.0 < lam < math.inf and 0.0 < dt < math.inf)
    ):
        return None
    if qdot_prev is None:
        inputs = _NO_INPUTS
    elif _plain(qdot_prev, seen.n):
        inputs = (_EMPTY, _EMPTY, cast(FloatArray, qdot_prev), _EMPTY)
    else:
        return None
    parts = seen.layout[1]
    buf = seen.spares.take()[0]  # held by the result's qdot and diagnostics, if kept
    law_pack, limits_t = seen.bound
    entry = seen.entry
    if entry[0]:
        lmask, smask, nvec = entry[0](q, J1, e1, law_pack, limits_t, (lam, dt), inputs, buf)
    else:
        args = (q, J1, e1, law_pack, limits_t, (lam, dt), inputs, buf)
        lmask, smask, nvec = _KC.law_into(*args)
        if entry[0] is None:  # looked up once: False when there is none
            entry[0] = entry_of(_KC.law_into, args) or False
    if lmask < 0 or nvec < 0:
        return False
    qdot = buf[parts[0]]
    safety = (q.copy(), qdot.copy(), dt, limits) if smask else None
    return qdot, (type(law), seen.state, J1.shape[0], buf, parts, (lmask, smask, nvec), safety)


def fast_call(law: Law, args: tuple[Any, ...]) -> tuple[FloatArray, DiagnoseArgs] | None:
    """``(q̇, the arguments of diagnose)`` of ``law(J1=..., ...)`` with ``args`` ``(J1, e1,
    q, limits, lam, dt, de1_dt, secondary, qdot_prev)`` when they have the signature the
    kernel takes (C-contiguous float64 arrays of matching shapes, a JointLimits of ``n``
    joints, float gains or an :class:`~redservo.AdaptiveGain`): no Python check of the
    values, which the kernel's own check (finite, below 1e300, ``q`` within the limits)
    makes. None for anything else: the caller then validates the inputs in full
    (:func:`~redservo.redundancy.inputs.validate_inputs`), which names a faulty argument.

    A plain call (no optional input but ``qdot_prev``, float gains) keeps its signature on
    the law (:class:`Seen`), so that the next call with the same one takes :func:`quick`."""
    J1, e1, q, limits, lam, dt, de1_dt, secondary, qdot_prev = args
    if type(J1) is not np.ndarray or J1.ndim != 2 or not isinstance(dt, float):
        return None
    m, n = J1.shape
    if m == 0 or not (_array(J1, (m, n)) and _array(e1, (m,)) and _array(q, (n,))):
        return None
    bound = _bound(law, limits, n)
    if bound is None:
        return None
    plain = isinstance(lam, float) and de1_dt is None and secondary is None
    if isinstance(lam, AdaptiveGain):
        lam = gain_value(lam, e1)
    elif not isinstance(lam, float):  # a Python or numpy float; anything else: full checks
        return None
    lam, dt = float(lam), float(dt)
    if not (0.0 < lam < math.inf and 0.0 < dt < math.inf):
        return None
    if de1_dt is None and secondary is None and qdot_prev is None:
        inputs = _NO_INPUTS
    elif all(
        v is None or _array(v, (k,)) for v, k in ((de1_dt, m), (secondary, n), (qdot_prev, n))
    ):
        inputs = (_given(de1_dt), _given(secondary), _given(qdot_prev), _EMPTY)
    else:
        return None
    if plain:
        law.__dict__[_SEEN] = Seen(law, cast(JointLimits, limits), (m, n), bound)
    return _into(law, (J1, e1, q), cast(JointLimits, limits), bound, (lam, dt), inputs, _slices(n))


def _plain(a: object, shape: tuple[int, ...]) -> bool:
    """``a`` is a float64 array of shape ``shape``, C-contiguous, aligned and writeable (the
    arrays of the signature :func:`fast_call` keeps, whose kernel entry it calls)."""
    if type(a) is not np.ndarray:
        return False
    return a.dtype == _F64 and a.shape == shape and bool(a.flags.carray)
