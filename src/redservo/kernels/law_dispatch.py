"""The law kernels by id: a compiled dispatch generated from the laws' declarations.

Every registered law that declares its kernel (``KERNEL``,
:class:`redservo.redundancy.declare.LawKernel`, and its option slots,
:func:`redservo.redundancy.options.slotted`) gets an id, in registration order
(:data:`LAW_IDS`), and a branch in two functions generated once, when this module is first
imported, and compiled like every kernel (:data:`SOURCE` shows them):

* ``raw_law(law, limits, gains, J1, e1, e, q, io)``: the raw command and outputs of law
  ``law[0]`` in the common layout of :mod:`redservo.kernels.laws`, its arguments bound by
  the names the law declares (its options read from their slots);
* ``law_events(law_id, fopt, m, iout, fout, axes, axf, vec)``: ``(mask, vals, src)`` of its
  events (:mod:`redservo.kernels.events`); an events kernel may read float options only.

:mod:`redservo.kernels.step` adds the safety layer and the flag rules. The generated source
is part of the numba cache stamp of this module and of its importers
(:func:`redservo.kernels._jit.add_stamp`), with the source files of kernels declared outside
this package: a law added, removed or edited recompiles the step, a cached step is reused
otherwise. A law registered after this module was imported has no compiled step in that
process (:func:`redservo.redundancy.kio.law_options` says so): import its module first.
Units: as the laws' (rad or m, s, 1/s).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from redservo.errors import ConfigurationError
from redservo.kernels import _jit
from redservo.kernels._jit import kernel
from redservo.redundancy.declare import LawKernel, declared_laws
from redservo.redundancy.options import COMMON_SLOTS

__all__ = [
    "F_SNS_SCALE",
    "I_SNS_BAD",
    "I_SNS_RESTORED",
    "LAW_IDS",
    "SOURCE",
    "law_events",
    "raw_law",
]

_RAW_HEAD = """\
def raw_law(law, limits, gains, J1, e1, e, q, io):
    law_id, fopt, iopt, vopt = law
    lp, has_v, has_a = limits
    lam, dt = gains
    ff, has_ff, sec, has_sec, prev, has_prev, hist, has_hist = io
"""
_EVENTS_HEAD = """\
def law_events(law_id, fopt, m, iout, fout, axes, axf, vec):
    n = axes.shape[0]
"""
_INPUTS = frozenset(
    "law limits gains J1 e1 e q io lp has_v has_a lam dt ff has_ff sec has_sec prev has_prev"
    " hist has_hist".split()
)
_EVENT_INPUTS = frozenset("m n iout fout axes axf vec".split())
_PACKS = {"f": "fopt", "i": "iopt", "v": "vopt"}
_OUTS = {"i": "iout", "f": "fout"}


def _slots(cls: Any) -> dict[str, tuple[str, int]]:
    """Every packed name of law class ``cls`` and its slot."""
    own = {o.name: o.slot for o in cls.OPTIONS if o.slot is not None}
    return {**COMMON_SLOTS, **own, **getattr(cls, "SLOTS", {})}


def _bind(token: str, names: frozenset[str], cls: Any, events: bool) -> str:
    """The expression of one declared argument (:mod:`redservo.redundancy.declare`)."""
    decl: LawKernel = cls.KERNEL
    where = f"{cls.__name__}.KERNEL"
    flag = token.endswith("?")
    name = token.rstrip("?")
    if name in names and not flag:
        return name
    if name.startswith("opt."):
        slot = _slots(cls).get(name[4:])
        if slot is None or (events and slot[0] != "f"):
            raise ConfigurationError(
                f"{where}: {token!r} is not a packed option of {cls.name!r}"
                + (" (an events kernel reads float options only)" if events else ""),
                argument="KERNEL",
            )
        expr = f"{_PACKS[slot[0]]}[{slot[1]}]"
    elif name.startswith("out.") and events:
        kind, index = decl.output(name[4:])
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


def _branches(calls: list[tuple[int, str]], indent: str = "    ") -> str:
    """An ``if`` chain returning each call, the ids with the same call sharing a branch,
    the last one unconditional (numba needs every path to return)."""
    groups: dict[str, list[int]] = {}
    for law_id, call in calls:
        groups.setdefault(call, []).append(law_id)
    lines = []
    for k, (call, ids) in enumerate(groups.items()):
        if k < len(groups) - 1:
            cond = " or ".join(f"law_id == {i}" for i in ids)
            lines += [f"{indent}if {cond}:", f"{indent}    return {call}"]
        else:
            lines.append(f"{indent}return {call}")
    return "\n".join(lines) + "\n"


def _generate(laws: list[tuple[str, Any]]) -> tuple[str, dict[str, Any], bytes]:
    """``(source, kernels by generated name, stamp)`` of the dispatch of ``laws``."""
    refs: dict[str, str] = {}
    found: dict[str, Any] = {}
    extra = b""

    def ref(path: str, cls: Any) -> str:
        nonlocal extra
        if path not in refs:
            module, _, func = path.partition(":")
            try:
                mod = importlib.import_module(module)
                found[f"_k{len(refs)}"] = getattr(mod, func)
            except (ImportError, AttributeError, ValueError):
                raise ConfigurationError(
                    f"{cls.__name__}.KERNEL: no kernel {path!r} (expected 'module:function')",
                    argument="KERNEL",
                ) from None
            refs[path] = f"_k{len(refs)}"
            if Path(mod.__file__ or "").resolve().parent != Path(__file__).resolve().parent:
                extra += Path(mod.__file__ or "").read_bytes()
        return refs[path]

    raw, ev = [], []
    for law_id, (_, cls) in enumerate(laws):
        decl: LawKernel = cls.KERNEL
        args = ", ".join(_bind(t, _INPUTS, cls, False) for t in decl.args.split())
        raw.append((law_id, f"{ref(decl.kernel, cls)}({args})"))
        names = _INPUTS | _EVENT_INPUTS
        args = ", ".join(_bind(t, names, cls, True) for t in decl.event_args.split())
        ev.append((law_id, f"{ref(decl.events, cls)}({args})"))
    source = _RAW_HEAD + _branches(raw) + "\n\n" + _EVENTS_HEAD + _branches(ev)
    return source, found, source.encode() + extra


_LAWS = declared_laws()
LAW_IDS: dict[str, int] = {name: i for i, (name, _) in enumerate(_LAWS)}
"""Methods with a fully compiled step, and their ids (registration order)."""
SOURCE, _KERNELS, _STAMP = _generate(_LAWS)
"""The generated source of ``raw_law`` and ``law_events`` (module docstring)."""
_jit.add_stamp(Path(__file__).stem, _STAMP)

raw_law: Callable[..., Any]
law_events: Callable[..., Any]
_namespace: dict[str, Any] = {}
globals().update(_KERNELS)
exec(compile(SOURCE, __file__, "exec"), globals(), _namespace)
raw_law = kernel(_namespace["raw_law"])
law_events = kernel(_namespace["law_events"])


def _output(method: str, name: str) -> int:
    """The index of the named output ``name`` of ``method`` (-1 when not declared)."""
    cls = dict(_LAWS).get(method)
    return -1 if cls is None else cls.KERNEL.output(name)[1]


I_SNS_RESTORED, I_SNS_BAD, F_SNS_SCALE = (
    _output("sns", "restored"),
    _output("sns", "bad_joint"),
    _output("sns", "scale"),
)
"""Where ``sns``'s restored flag, infeasible joint and task scale are (its declaration)."""
