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

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from redservo.errors import ConfigurationError
from redservo.kernels import law_table
from redservo.kernels.law_table import BoundLaw
from redservo.redundancy.options import COMMON_SLOTS

__all__ = ["OUTPUTS", "LawKernel", "bind_law", "bound_laws", "declared_laws", "kernel_class"]

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


def declared_laws(registry: Mapping[str, Any]) -> list[tuple[str, Any]]:
    """``(method, class)`` of every law of ``registry`` (name -> class, in registration
    order) that declares its kernel (``KERNEL`` in the class itself, not inherited: a
    subclass may compute otherwise)."""
    return [(name, cls) for name, cls in registry.items() if "KERNEL" in cls.__dict__]


_INPUTS = frozenset(
    "law limits gains J1 e1 e q io lp has_v has_a lam dt ff has_ff sec has_sec prev has_prev"
    " hist has_hist".split()
)
"""The names of the generated ``raw_law`` (:mod:`redservo.kernels.law_dispatch`)."""
_EVENT_INPUTS = _INPUTS | frozenset("m n iout fout axes axf vec".split())
"""The names of the generated ``law_events``."""
_PACKS = {"f": "fopt", "i": "iopt", "v": "vopt"}
_OUTS = {"i": "iout", "f": "fout"}
_KERNELS_DIR = Path(law_table.__file__).resolve().parent


def law_slots(cls: Any) -> dict[str, tuple[str, int]]:
    """Every packed name of the law class ``cls`` and its slot ``(kind, index)``."""
    own = {o.name: o.slot for o in cls.OPTIONS if o.slot is not None}
    return {**COMMON_SLOTS, **own, **getattr(cls, "SLOTS", {})}


def _bind(token: str, cls: Any, events: bool) -> str:
    """The expression of one declared argument (module docstring)."""
    where = f"{cls.__name__}.KERNEL"
    flag = token.endswith("?")
    name = token.rstrip("?")
    names = _EVENT_INPUTS if events else _INPUTS
    if name in names and not flag:
        return name
    if name.startswith("opt."):
        slot = law_slots(cls).get(name[4:])
        if slot is None or (events and slot[0] != "f"):
            only = " (an events kernel reads float options only)" if events else ""
            raise ConfigurationError(
                f"{where}: {token!r} is not a packed option of {cls.name!r}{only}",
                argument="KERNEL",
            )
        expr = f"{_PACKS[slot[0]]}[{slot[1]}]"
    elif name.startswith("out.") and events:
        kind, index = cls.KERNEL.output(name[4:])
        expr = f"{_OUTS[kind]}[{index}]"
    else:
        try:
            return repr(float(token))
        except ValueError:
            raise ConfigurationError(
                f"{where}: unknown argument {token!r}; allowed: {', '.join(sorted(names))},"
                " opt.NAME, out.NAME (events), a number",
                argument="KERNEL",
            ) from None
    return f"({expr} != 0)" if flag else expr


def _resolve(path: str, cls: Any) -> tuple[Callable[..., Any], bytes]:
    """The kernel ``"module:function"`` and its module's source when outside
    ``redservo/kernels/`` (part of the cache stamp)."""
    module, _, func = path.partition(":")
    try:
        mod = importlib.import_module(module)
        fn = getattr(mod, func)
    except (ImportError, AttributeError, ValueError):
        raise ConfigurationError(
            f"{cls.__name__}.KERNEL: no kernel {path!r} (expected 'module:function')",
            argument="KERNEL",
        ) from None
    file = Path(mod.__file__ or "").resolve()
    return fn, b"" if file.parent == _KERNELS_DIR else file.read_bytes()


def bind_law(name: str, cls: Any) -> BoundLaw:
    """The declaration of ``cls`` bound for the generated dispatch (module docstring).

    Raises:
        ConfigurationError: an unknown argument, option or kernel, naming ``Class.KERNEL``.
    """
    decl: LawKernel = cls.KERNEL
    kern, stamp = _resolve(decl.kernel, cls)
    events, stamp2 = _resolve(decl.events, cls)
    return BoundLaw(
        name,
        kern,
        ", ".join(_bind(t, cls, False) for t in decl.args.split()),
        events,
        ", ".join(_bind(t, cls, True) for t in decl.event_args.split()),
        {**OUTPUTS, **decl.outputs},
        stamp + stamp2,
    )


def bound_laws(registry: Mapping[str, Any]) -> list[BoundLaw]:
    """Every declared law of ``registry`` (:func:`declared_laws`), bound; what
    :mod:`redservo.redundancy` provides to :mod:`redservo.kernels.law_table`."""
    return [bind_law(name, cls) for name, cls in declared_laws(registry)]
