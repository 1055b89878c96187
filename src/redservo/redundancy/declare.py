"""A law's compiled kernel, declared once beside its class (docs/extending.md).

A law class with a compiled step sets ``KERNEL`` to a :class:`LawKernel` and its options
with :func:`~redservo.redundancy.options.slotted` (which numbers their slots). From these
declarations alone :mod:`redservo.kernels.law_dispatch` builds, when the step kernel is
first imported, the law ids (:data:`~redservo.kernels.law_dispatch.LAW_IDS`) and the
compiled dispatch from an id to the law's kernel and to its events: a new law is its class
module (and its kernel, in the same file or a kernel module), nothing else.

Arguments are written as names, each bound by the generated dispatch:

* the step's inputs: ``J1`` (m, n), ``e1`` (m,) the task error, ``e`` (m,) the effective
  error ``e1 + ff/λ``, ``q`` (n,) rad or m, ``lp`` the limit rows, ``has_v``, ``has_a``,
  ``lam`` (1/s), ``dt`` (s), ``ff``/``has_ff``, ``sec``/``has_sec``, ``prev``/``has_prev``,
  ``hist``/``has_hist`` (each optional array with its flag), and the packs ``law``,
  ``limits``, ``gains``, ``io`` (:mod:`redservo.kernels.step`);
* for the events kernel also ``m``, ``n`` and the law kernel's outputs ``iout``, ``fout``,
  ``axes``, ``axf``, ``vec`` (:mod:`redservo.kernels.laws`);
* ``opt.NAME``: the packed option or extra ``NAME`` (its slot from the class's ``SLOTS``);
  ``opt.NAME?`` the same as a bool (``!= 0``);
* ``out.NAME``: the named output ``NAME`` (:data:`OUTPUTS` or the declaration's
  ``outputs``), ``out.NAME?`` as a bool;
* a number, passed as written.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["OUTPUTS", "LawKernel", "declared_laws", "kernel_class"]

OUTPUTS: Mapping[str, tuple[str, int]] = {
    "rank": ("i", 0),
    "filtered": ("i", 1),
    "projector_rank": ("i", 2),
    "iterations": ("i", 3),
    "overconstrained": ("i", 4),
    "cond": ("f", 0),
    "alpha": ("f", 1),
    "scale": ("f", 2),
}
"""The outputs every law kernel writes at the same place (:mod:`redservo.kernels.laws`):
``(array, index)``, ``"i"`` for ``iout``, ``"f"`` for ``fout``."""


@dataclass(frozen=True)
class LawKernel:
    """How the compiled step calls a law.

    Attributes:
        kernel: ``"module:function"`` of the law kernel; it returns ``(q̇, iout, fout,
            axes, axf, vec)`` (:mod:`redservo.kernels.laws`), q̇ in rad/s or m/s.
        args: Its arguments, as names separated by spaces (module docstring).
        events: ``"module:function"`` of its events kernel (:mod:`redservo.kernels.events`),
            returning ``(mask, vals, src)``.
        event_args: The events kernel's arguments, as ``args``.
        outputs: The law's own named outputs, ``name -> ("i" | "f", index)``; the one
            place their indices are written.
    """

    kernel: str
    args: str
    events: str
    event_args: str
    outputs: Mapping[str, tuple[str, int]] = field(default_factory=dict)

    def output(self, name: str) -> tuple[str, int]:
        """Where the output ``name`` is, ``("i" | "f", index)``."""
        return {**OUTPUTS, **self.outputs}[name]


def kernel_class(cls: type) -> type | None:
    """The class whose declared kernel computes ``cls``: the nearest class of its MRO with
    ``KERNEL`` in its own namespace, when it is defined in the same module as ``cls`` (an
    internal variant, as ``wln``'s history mode); None otherwise (a subclass elsewhere may
    compute otherwise, it takes the object path)."""
    for k in cls.__mro__:
        if "KERNEL" in k.__dict__:
            return k if k.__module__ == cls.__module__ else None
    return None


def declared_laws() -> list[tuple[str, Any]]:
    """``(method, class)`` of every registered law that declares its kernel (``KERNEL`` in
    the class itself, not inherited: a subclass may compute otherwise), in registration
    order."""
    from redservo.redundancy import registered_methods

    return [(name, cls) for name, cls in registered_methods().items() if "KERNEL" in cls.__dict__]
