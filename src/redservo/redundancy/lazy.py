"""Diagnostics built when first read: :class:`LazyDiagnostics`.

A law call through the step kernel (:mod:`redservo.redundancy.kernel_call`) and the
compiled :class:`~redservo.control.Controller` step end with the kernel's raw outputs
(integer and float codes, event masks). Turning them into a frozen
:class:`~redservo.Diagnostics` with worded events costs more than the law itself on a
small arm, and a control loop that only sends ``qdot`` never reads it. A
:class:`LazyDiagnostics` is a :class:`~redservo.Diagnostics` whose fields are computed on
the first read of any of them, from a copy of what the kernel wrote (the law's options
as they were at the call, the command and joint positions when the safety layer
acted), so that a later change of the law, of ``q`` or of ``qdot`` in place does not
change what it says. It compares equal to the eager diagnostics, prints and pickles as a
plain :class:`~redservo.Diagnostics`.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from dataclasses import fields
from typing import Any

from redservo.redundancy.base import Diagnostics

__all__ = ["LazyDiagnostics", "lazy_diagnostics"]

_NAMES = tuple(f.name for f in fields(Diagnostics))
_ALL = operator.attrgetter(*_NAMES)
"""Every field of a :class:`~redservo.Diagnostics`, in order."""


class LazyDiagnostics(Diagnostics):
    """A :class:`~redservo.Diagnostics` computed on first read (module docstring)."""

    __slots__ = ("_build",)

    def __getattr__(self, name: str) -> Any:
        """Called only for a field not yet set: build them all, then read ``name``."""
        try:
            build = object.__getattribute__(self, "_build")
        except AttributeError:  # made by ``dataclasses.replace``: every field is set
            raise AttributeError(name) from None
        if build is None or name not in _NAMES:
            raise AttributeError(name)
        fn, args = build
        try:
            eager = fn(*args)
        except AttributeError as err:  # not a missing field: say what failed
            raise RuntimeError(f"building the diagnostics failed: {err}") from err
        for key, value in zip(_NAMES, _ALL(eager), strict=True):
            object.__setattr__(self, key, value)
        object.__setattr__(self, "_build", None)
        return object.__getattribute__(self, name)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Diagnostics):
            return bool(_ALL(self) == _ALL(other))
        return NotImplemented

    __hash__ = Diagnostics.__hash__

    def __repr__(self) -> str:
        return repr(self.eager())

    def __reduce__(self) -> tuple[Any, ...]:
        return (Diagnostics, _ALL(self))

    def eager(self) -> Diagnostics:
        """The same diagnostics as a plain :class:`~redservo.Diagnostics`."""
        return Diagnostics(*_ALL(self))


def lazy_diagnostics(fn: Callable[..., Diagnostics], *args: Any) -> LazyDiagnostics:
    """Diagnostics that are ``fn(*args)``, computed when first read (``args`` must not
    change in the meantime: pass copies of anything the caller may modify)."""
    d = object.__new__(LazyDiagnostics)
    object.__setattr__(d, "_build", (fn, args))
    return d
