"""Glue between the laws and their kernels: inputs as plain arrays, outputs as diagnostics.

A law's :meth:`~redservo.redundancy.Law.compute` calls one kernel of
:mod:`redservo.kernels` with :func:`kernel_inputs` and reads the kernel's fixed-size
integer and float outputs (layout in :mod:`redservo.kernels.laws`) back into a
:class:`~redservo.Diagnostics`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.kernels.lawopts import NF, NI
from redservo.redundancy.packs import limits_pack

if TYPE_CHECKING:
    from redservo.redundancy.base import Law, LawInputs

__all__ = [
    "I_FILTERED",
    "I_PROJ",
    "I_RANK",
    "KernelInputs",
    "LawOptions",
    "LawOutputs",
    "kernel_inputs",
    "law_options",
    "levels",
    "optional",
    "pack_options",
    "task_context",
]

I_RANK, I_FILTERED, I_PROJ, I_ITER, I_OVER = 0, 1, 2, 3, 4
F_COND, F_ALPHA, F_SCALE = 0, 1, 2

_ZEROS: dict[int, FloatArray] = {}


def optional(value: FloatArray | None, n: int) -> tuple[FloatArray, bool]:
    """An optional (n,) array as a kernel takes it: the array (zeros if None) and a flag."""
    if value is None:
        z = _ZEROS.get(n)
        if z is None:
            z = _ZEROS[n] = np.zeros(n)
        return z, False
    return np.ascontiguousarray(value, dtype=np.float64), True


class LawOutputs(NamedTuple):
    """A law kernel's outputs in the common layout of :mod:`redservo.kernels.laws`, and its
    events: what a law's ``diagnose(m, out)`` reads (from its own kernel call, or from the
    compiled controller's buffer, :mod:`redservo.kernels.control`; integer outputs may then
    be float64 holding integers)."""

    iout: NDArray[Any]
    """(16,) integer outputs (rank, filtered count, projector rank, ...)."""
    fout: FloatArray
    """(16,) float outputs (``σ_max/σ_r``, α, ...)."""
    axes: NDArray[Any]
    """(n,) per axis, the level at which it is constrained (0: none)."""
    axf: FloatArray
    """(n,) per-law numbers (γ, gpm-auto's candidates)."""
    vec: FloatArray
    """Per-law vector (the gains a and b)."""
    mask: int
    """The law's event mask (:mod:`redservo.kernels.flagbits`)."""
    vals: FloatArray
    """(20,) the events' values."""
    src: NDArray[Any]
    """(20,) the events' source bits."""


class KernelInputs(NamedTuple):
    """:class:`~redservo.redundancy.base.LawInputs` as C-contiguous arrays and flags."""

    J1: FloatArray
    e: FloatArray
    q: FloatArray
    lp: FloatArray
    has_v: bool
    has_a: bool
    sec: FloatArray
    has_sec: bool


def kernel_inputs(x: LawInputs) -> KernelInputs:
    """Contiguous ``J1``, the effective error, ``q``, the packed limits and ``secondary``."""
    n = x.J1.shape[1]
    pack = limits_pack(x.limits)
    sec, has_sec = optional(x.secondary, n)
    return KernelInputs(
        np.ascontiguousarray(x.J1),
        np.ascontiguousarray(x.e_eff),
        np.ascontiguousarray(x.q),
        pack.rows,
        pack.has_v,
        pack.has_a,
        sec,
        has_sec,
    )


def task_context(
    m: int, iout: NDArray[np.int64], fout: FloatArray, robust: float
) -> dict[str, Any]:
    """The numbers the task-inverse messages name (:mod:`redservo.redundancy.messages`): the
    rank, ``m``, ``σ_max/σ_r``, the filtered count and the amplification bound ``1/ε``."""
    return {
        "rank": int(iout[I_RANK]),
        "m": m,
        "cond": float(fout[F_COND]),
        "filtered": int(iout[I_FILTERED]),
        "inv_robust": 1.0 / robust if robust else np.inf,
    }


def levels(axes: NDArray[np.int64], count: int | None = None) -> tuple[tuple[int, ...], ...]:
    """``((axes at level 1), (level 2), ...)`` from a kernel's per-axis level marks."""
    top = int(axes.max()) if count is None and axes.size else (count or 0)
    return tuple(tuple(int(i) for i in np.flatnonzero(axes == lv)) for lv in range(1, top + 1))


class LawOptions(NamedTuple):
    """A law's options as :func:`redservo.kernels.step.law_step` takes them."""

    law_id: int
    fopt: FloatArray
    iopt: NDArray[np.int64]
    vopt: FloatArray


def law_options(law: Law, n: int) -> LawOptions:
    """Pack ``law``'s options for the compiled step: each declared option into its slot
    (``Law.OPTIONS``, :mod:`redservo.kernels.lawopts`), then ``law.packed_extras()``.

    Raises:
        ConfigurationError: the law has no compiled step (``qp``, user-defined laws).
    """
    from redservo.kernels.step import LAW_IDS

    name = law.name
    from redservo.redundancy.declare import kernel_class

    owner = kernel_class(type(law))
    if name not in LAW_IDS or owner is None or getattr(owner, "name", None) != name:
        raise ConfigurationError(
            f"method {name!r} has no compiled step; compiled methods: {', '.join(LAW_IDS)}",
            argument="method",
        )
    return pack_options(law, n, LAW_IDS[name])


def pack_options(law: Law, n: int, law_id: int) -> LawOptions:
    """``law``'s options in the slots of the law kernel ``law_id`` (no check that the law
    is that kernel's: :func:`law_options` checks it for the engine; a subclass of a shipped
    law calling its parent's ``compute`` packs its options for its parent's kernel)."""
    f = np.zeros(NF)
    i = np.zeros(NI, dtype=np.int64)
    v = np.full((2, n), np.inf)
    packed = [(o.slot, o.pack(getattr(law, o.name))) for o in law.OPTIONS if o.slot is not None]
    for (kind, index), value in (*packed, *law.packed_extras()):
        if kind == "f":
            f[index] = value
        elif kind == "i":
            i[index] = value
        elif value is not None:
            v[index] = np.broadcast_to(value, (n,))
    return LawOptions(law_id, f, i, np.ascontiguousarray(v))
