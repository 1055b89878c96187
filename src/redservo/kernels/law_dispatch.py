"""The law kernels by id: a compiled dispatch generated from the laws' declarations.

Every registered law that declares its kernel (``KERNEL``,
:class:`redservo.redundancy.declare.LawKernel`, and its option slots,
:func:`redservo.redundancy.options.slotted`; bound by that layer and taken here from
:func:`redservo.kernels.law_table.bound_laws`) gets an id, in registration order
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

from collections.abc import Callable
from pathlib import Path
from typing import Any

from redservo.kernels import _jit
from redservo.kernels._jit import kernel
from redservo.kernels.law_table import BoundLaw, bound_laws

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


def _generate(laws: list[BoundLaw]) -> tuple[str, dict[str, Any], bytes]:
    """``(source, kernels by generated name, stamp)`` of the dispatch of ``laws``."""
    names: dict[int, str] = {}
    found: dict[str, Any] = {}

    def ref(fn: Any) -> str:
        if id(fn) not in names:
            names[id(fn)] = f"_k{len(names)}"
            found[names[id(fn)]] = fn
        return names[id(fn)]

    raw = [(i, f"{ref(b.kernel)}({b.args})") for i, b in enumerate(laws)]
    ev = [(i, f"{ref(b.events)}({b.event_args})") for i, b in enumerate(laws)]
    source = _RAW_HEAD + _branches(raw) + "\n\n" + _EVENTS_HEAD + _branches(ev)
    own = _kernel_sources(found.values())
    return source, found, source.encode() + b"".join(b.stamp for b in laws) + own


def _kernel_sources(fns: Any) -> bytes:
    """The sources of the modules of :mod:`redservo.kernels` that the kernels ``fns`` come
    from and of every kernel module those import (the laws' kernels and what they call,
    down to the SVD): part of the cache stamp, so that an edit of any of them recompiles
    the dispatch and its callers instead of linking their cached, older code."""
    here = Path(__file__).resolve().parent
    mods: set[str] = set()
    for fn in fns:
        package, _, stem = getattr(fn, "__module__", "").rpartition(".")
        if package == "redservo.kernels":
            mods.update(_jit._closure(stem))  # the stamp rule of _jit itself
    return b"".join(m.encode() + (here / f"{m}.py").read_bytes() for m in sorted(mods))


_LAWS = bound_laws()
LAW_IDS: dict[str, int] = {b.method: i for i, b in enumerate(_LAWS)}
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
    for b in _LAWS:
        if b.method == method:
            return b.outputs[name][1]
    return -1


I_SNS_RESTORED, I_SNS_BAD, F_SNS_SCALE = (
    _output("sns", "restored"),
    _output("sns", "bad_joint"),
    _output("sns", "scale"),
)
"""Where ``sns``'s restored flag, infeasible joint and task scale are (its declaration)."""
