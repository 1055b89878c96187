"""A law's options, declared once: name, kind, range, default, unit, paper reference, slot.

Each law lists its options as ``OPTIONS``, a tuple of :class:`Option`. From that one
declaration come its constructor (keyword-only, with these defaults: ``inspect.signature``
shows them), the validation of every value (one :class:`~redservo.errors.ConfigurationError`
naming the option and what it allows), ``repr``, :func:`redservo.make_law`'s list of options,
and the packing of the options for the compiled step
(:func:`redservo.redundancy.kio.law_options`, into the slots of
:mod:`redservo.kernels.lawopts`).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from redservo._validation import _to_float
from redservo.errors import ConfigurationError, ShapeError
from redservo.kernels.lawopts import F_RCOND, F_ROBUST, I_FIRST, I_SHIELD, NF, NI
from redservo.redundancy.linalg import DEFAULT_RCOND

__all__ = [
    "COMMON_SLOTS",
    "RCOND",
    "Option",
    "check_option",
    "constructor",
    "describe",
    "options_doc",
    "safety_options",
    "slotted",
]

Kind = Literal["float", "int", "bool", "choice", "str", "per-joint"]


@dataclass(frozen=True)
class Option:
    """One option of a law.

    Attributes:
        name: Keyword of the option.
        default: Its default value.
        kind: ``"float"``, ``"int"``, ``"bool"``, ``"choice"`` (one of ``choices``),
            ``"str"`` (any string; the law's ``_setup`` checks it further) or
            ``"per-joint"`` (a number > 0 or a 1-D array of them, one per joint).
        doc: What it is, one line.
        unit: Its unit ("" when dimensionless).
        ref: The paper and equation or section it comes from ("" when none).
        low, high: The allowed interval of a number (None: unbounded on that side).
        low_open, high_open: The interval is open at that end.
        finite: A number must be finite (``inf`` refused).
        none: None is allowed (it means: see ``doc``).
        choices: The allowed strings of a ``choice``.
        slot: Where the compiled step takes it, ``("f" | "i" | "v", index)`` in
            ``fopt``/``iopt``/``vopt``, or None; numbered by :func:`slotted` from
            ``slot_kind``, never by hand (but the slots every law shares,
            :data:`COMMON_SLOTS`).
        slot_kind: The slot it asks for: ``"f"`` (a float), ``"i"`` (an int, a bool, a
            choice's index) or ``"v"`` (a per-joint row); None: not packed.
        encode: How the value is packed into its slot (default: the number, a bool as 0/1,
            a choice as its index, None as inf for ``f``, -1 for ``i``, absent for ``v``).
    """

    name: str
    default: Any
    kind: Kind = "float"
    doc: str = ""
    unit: str = ""
    ref: str = ""
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    finite: bool = True
    none: bool = False
    choices: tuple[str, ...] = ()
    slot: tuple[str, int] | None = None
    encode: Callable[[Any], Any] | None = None
    slot_kind: Literal["f", "i", "v"] | None = None

    def allowed(self) -> str:
        """What the option allows, in words (used in errors and docs)."""
        if self.kind == "bool":
            text = "true or false"
        elif self.kind == "choice":
            text = "one of " + ", ".join(repr(c) for c in self.choices)
        elif self.kind == "str":
            text = "a string"
        elif self.kind == "per-joint":
            text = f"a finite number > 0 ({self.unit}) or a 1-D array of them, one per joint"
        else:
            what = (
                "an int" if self.kind == "int" else "a finite number" if self.finite else "a number"
            )
            text = f"{what} in {self.interval()}"
        return f"None or {text}" if self.none else text

    def interval(self) -> str:
        """The interval of a number, e.g. ``(0, 1]``."""
        lo = "-inf" if self.low is None else f"{self.low:g}"
        hi = "inf" if self.high is None else f"{self.high:g}"
        left = "(" if self.low is None or self.low_open else "["
        right = ")" if self.high is None or self.high_open else "]"
        return f"{left}{lo}, {hi}{right}"

    def pack(self, value: Any) -> Any:
        """The value as its slot holds it."""
        if self.encode is not None:
            return self.encode(value)
        if value is None:
            kind = None if self.slot is None else self.slot[0]  # "f", "i" or "v"
            return np.inf if kind == "f" else -1 if kind == "i" else None
        if self.kind == "choice":
            return self.choices.index(value)
        return int(value) if self.kind == "bool" else value


def _fail(option: Option, value: object) -> ConfigurationError:
    what = option.doc + (f", {option.unit}" if option.unit else "")
    label = f"{option.name} ({what})" if what else option.name
    return ConfigurationError(
        f"{label} must be {option.allowed()}, got {value!r}", argument=option.name
    )


def _number(option: Option, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise _fail(option, value)
    v = float(value)
    if math.isnan(v) or (option.finite and not math.isfinite(v)):
        raise _fail(option, value)
    lo, hi = option.low, option.high
    if lo is not None and (v < lo or (option.low_open and v == lo)):
        raise _fail(option, value)
    if hi is not None and (v > hi or (option.high_open and v == hi)):
        raise _fail(option, value)
    return v


def check_option(option: Option, value: Any) -> Any:
    """``value`` validated and normalized (a float, an int, a bool, a string, an array)."""
    if value is None:
        if option.none:
            return None
        raise _fail(option, value)
    if option.kind == "bool":
        if not isinstance(value, bool | np.bool_):
            raise _fail(option, value)
        return bool(value)
    if option.kind in ("choice", "str"):
        if not isinstance(value, str) or (option.kind == "choice" and value not in option.choices):
            raise _fail(option, value)
        return value
    if option.kind == "per-joint":
        try:
            arr = _to_float(value, option.name)  # numbers only: "2.0" is refused, not parsed
        except ShapeError:
            raise _fail(option, value) from None
        bad = arr.ndim > 1 or arr.size == 0 or not np.all(np.isfinite(arr))
        if bad or not np.all(arr > 0.0):
            raise _fail(option, value)
        return arr
    if option.kind == "int":
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise _fail(option, value)
        return int(_number(option, value))
    return _number(option, value)


def describe(options: tuple[Option, ...]) -> list[dict[str, Any]]:
    """The declarations as plain records (name, default, allowed, unit, reference, doc), for
    docs and schemas."""
    return [
        {
            "name": o.name,
            "default": o.default,
            "allowed": o.allowed(),
            "unit": o.unit,
            "ref": o.ref,
            "doc": o.doc,
        }
        for o in options
    ]


RCOND = Option(
    "rcond",
    DEFAULT_RCOND,
    doc="relative singular-value cut-off of the pseudo-inverse",
    low=0.0,
    high=1.0,
    low_open=True,
    high_open=True,
    slot=("f", F_RCOND),
)
"""The option every law has."""


def constructor(cls: type, init: Callable[..., None]) -> Callable[..., None]:
    """``init(self, **options)`` as ``cls.__init__``, its signature listing ``cls.OPTIONS``
    as keyword-only parameters with their defaults."""

    def __init__(self: Any, **options: Any) -> None:
        init(self, **options)

    options: tuple[Option, ...] = cls.OPTIONS  # type: ignore[attr-defined]
    params = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    params += [
        inspect.Parameter(o.name, inspect.Parameter.KEYWORD_ONLY, default=o.default)
        for o in options
    ]
    __init__.__signature__ = inspect.Signature(params)  # type: ignore[attr-defined]
    __init__.__qualname__ = f"{cls.__qualname__}.__init__"
    __init__.__doc__ = f"Create the law; its options: {', '.join(o.name for o in options)}."
    return __init__


def options_doc(options: tuple[Option, ...]) -> str:
    """The ``Options:`` section of a law's docstring, from its declarations (indented for a
    class docstring)."""
    lines = ["Options (declared in ``OPTIONS``, :mod:`redservo.redundancy.options`):"]
    for o in options:
        unit = f" ({o.unit})" if o.unit else ""
        ref = f"; {o.ref}" if o.ref else ""
        lines.append(f"    {o.name}: {o.doc}{unit}; {o.allowed()}; default {o.default!r}{ref}.")
    return "\n    ".join(["", *lines])


COMMON_SLOTS: dict[str, tuple[str, int]] = {
    "rcond": ("f", F_RCOND),
    "robust": ("f", F_ROBUST),
    "shield": ("i", I_SHIELD),
    "first": ("i", I_FIRST),
}
"""The slots every law packs (:meth:`redservo.redundancy.Law.packed_extras`)."""
_SIZES = {"f": NF, "i": NI, "v": 2}


def slotted(
    options: tuple[Option, ...], packed: tuple[tuple[str, str], ...] = ()
) -> tuple[tuple[Option, ...], dict[str, tuple[str, int]]]:
    """A law's ``(OPTIONS, SLOTS)``: the options with their slots numbered in declaration
    order (each its ``slot_kind``) after the common ones (:data:`COMMON_SLOTS`), then the ``packed`` extras
    ``(name, kind)`` its ``packed_extras`` computes; ``SLOTS`` maps every packed name to
    its ``(kind, index)``, which the generated dispatch reads (``opt.NAME`` in
    :class:`~redservo.redundancy.declare.LawKernel`)."""
    nxt = {"f": 2, "i": 2, "v": 0}
    slots = dict(COMMON_SLOTS)
    out = []

    def take(kind: str) -> tuple[str, int]:
        if nxt[kind] >= _SIZES[kind]:
            raise ConfigurationError(f"more than {_SIZES[kind]} packed {kind!r} slots")
        nxt[kind] += 1
        return kind, nxt[kind] - 1

    for o in options:
        if o.slot_kind is not None and o.slot is None:
            o = replace(o, slot=take(o.slot_kind))
        if o.slot is not None:
            slots[o.name] = o.slot
        out.append(o)
    for name, kind in packed:
        slots[name] = take(kind)
    return tuple(out), slots


def safety_options(shield: Any, robust: Any, scaling: Any) -> dict[str, Any]:
    """The safety options :meth:`~redservo.redundancy.base.Law.set_safety` sets, checked:
    ``shield`` and ``robust`` booleans, ``scaling`` ``"uniform"`` or ``"secondary-first"``;
    None keeps the current value (left out). Anything else is a
    :class:`~redservo.errors.ConfigurationError` naming the option."""
    out: dict[str, Any] = {}
    for key, value in (("shield", shield), ("robust", robust)):
        if value is not None:
            if not isinstance(value, bool | np.bool_):
                raise ConfigurationError(
                    f"{key} must be true or false, got {value!r}", argument=key
                )
            out[key] = bool(value)
    if scaling is not None:
        if scaling not in ("uniform", "secondary-first"):
            raise ConfigurationError(
                f"scaling must be 'uniform' or 'secondary-first', got {scaling!r}",
                argument="scaling",
            )
        out["scaling"] = scaling
    return out
