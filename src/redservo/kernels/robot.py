"""The kinematics of any robot pack: one compiled dispatch over the declared robot kinds.

The pack is the one of :mod:`redservo.robots.pack`, ``(code, eMc, cVe, scalars, table,
frames)``; the code selects the kind's kinematics kernel (:mod:`redservo.kernels.robot_kinds`:
0 the Afma6, 1 a DH chain, 2 a chain of fixed transforms and joint axes, then the kinds
declared outside the package). :func:`robot_kinematics` is generated from that table when
this module is first imported (:data:`SOURCE` shows it) and compiled like every kernel; it
is what every driver of the step kernel calls (the Controller's step of
:mod:`redservo.kernels.control`, the campaign loop). The robot objects call their kind's
kernel directly, with the same arguments, so the numbers are the same to the bit.

The generated source and the source of the kind kernels (their module and the kernel
modules it imports) are part of the numba cache stamp of this module and of its importers
(:func:`redservo.kernels._jit.add_stamp`): a kind added or edited recompiles the step once.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from redservo.kernels import _jit
from redservo.kernels._jit import kernel
from redservo.kernels.robot_kinds import freeze

__all__ = ["SOURCE", "robot_kinematics"]

_HEAD = """\
def robot_kinematics(q, robot):
    kind, eMc, cVe, scalars, table, frames = robot
"""


def _source_stamp(module: Any) -> bytes:
    """The cache stamp of a kind kernel's module: its source and, inside the kernels
    package, the kernel modules it imports."""
    file = Path(module.__file__ or "").resolve()
    if file.parent == Path(_jit.__file__).resolve().parent:
        return _jit._stamp(str(file)).encode()
    return file.read_bytes()


def _generate(kinds: list[tuple[str, str]]) -> tuple[str, dict[str, Any], bytes]:
    """``(source, kernels by generated name, stamp)`` of the dispatch over ``kinds``."""
    found: dict[str, Any] = {}
    lines = []
    stamp = b""
    for code, (_, path) in enumerate(kinds):
        module_name, _, func = path.partition(":")
        module = importlib.import_module(module_name)
        found[f"_k{code}"] = getattr(module, func)
        stamp += _source_stamp(module)
        call = f"return _k{code}(q, eMc, cVe, scalars, table, frames)"
        if code < len(kinds) - 1:
            lines += [f"    if kind == {code}:", f"        {call}"]
        else:
            lines.append(f"    {call}")  # numba: every path returns
    source = _HEAD + "\n".join(lines) + "\n"
    return source, found, source.encode() + stamp


SOURCE, _KERNELS, _STAMP = _generate(freeze())
"""The generated source of :func:`robot_kinematics` (module docstring)."""
_jit.add_stamp(Path(__file__).stem, _STAMP)

robot_kinematics: Callable[..., Any]
"""``(bMc, J)``: the camera pose (4, 4; m) and ``J = cVe eJe`` (6, n) at ``q`` (n,; rad or m)
of the robot pack ``robot`` (module docstring)."""
_namespace: dict[str, Any] = {}
globals().update(_KERNELS)
exec(compile(SOURCE, __file__, "exec"), globals(), _namespace)
robot_kinematics = kernel(_namespace["robot_kinematics"])
