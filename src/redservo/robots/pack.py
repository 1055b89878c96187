"""The one form in which a robot enters the compiled engine (:mod:`redservo.kernels.robot`).

A robot with compiled kinematics declares its kind once, beside its class
(``KIND = RobotKind("name", "module:function")``: the kind's name and kinematics kernel),
and packs itself (:meth:`redservo.robots.Robot.kernel_pack`, ``self.KIND.pack(...)``) into
one tuple of fixed layout, whatever its kind, so that every driver of the step kernel (the
:class:`~redservo.control.Controller`, the campaign loop, the benchmarks) takes the same
pack:

``(code, eMc, cVe, scalars, table, frames)``

* ``code``: the kind's code (:mod:`redservo.kernels.robot_kinds`; :data:`AFMA6` 0,
  :data:`DH` 1, :data:`CHAIN` 2, then the kinds declared outside the package);
* ``eMc`` (4, 4) the hand-eye transform (m) and ``cVe`` (6, 6) its twist transform;
* ``scalars`` (k,), ``table`` (r, c), ``frames`` (f, a, b): the kind's own numbers, as its
  kernel reads them (the Afma6: ``scalars = (coupling, offset)``; a DH chain: ``scalars =
  (standard,)``, ``table`` its (8, n) table, ``frames`` its base and flange; a chain:
  ``table`` its (n, 4) joint axes, ``frames`` its (n + 1, 3, 4) fixed transforms).

Parts a kind does not use are empty arrays of the same numba types, so one compiled
signature serves every robot of a given joint count. The kind kernel's signature is
``kernel(q, eMc, cVe, scalars, table, frames) -> (bMc, J)`` (4, 4; m and 6, n).
"""

from __future__ import annotations

import importlib
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo.errors import ConfigurationError
from redservo.kernels import robot_kinds

__all__ = ["AFMA6", "CHAIN", "DH", "RobotKind", "RobotPack"]

AFMA6, DH, CHAIN = 0, 1, 2
"""Codes of the shipped kinds (:data:`redservo.kernels.robot_kinds.SHIPPED`)."""

RobotPack = tuple[Any, ...]


class RobotKind:
    """A robot kind: its name and kinematics kernel (module docstring).

    ``RobotKind("afma6")`` names a shipped kind; ``RobotKind("scara", "pkg.mod:kernel")``
    declares a new one, which gets the next code when it is declared before the first
    compiled step of the process (import its module first). Declared later, its robots run
    on the object path in this process (:meth:`pack` gives None), with a RuntimeWarning.

    Raises:
        ConfigurationError: an unknown shipped kind, a kernel not written
            ``"module:function"`` or not found (define it before the declaration), or a
            name already declared with another kernel.
    """

    def __init__(self, name: str, kernel: str | None = None) -> None:
        self.name = name
        shipped = dict(robot_kinds.SHIPPED)
        if kernel is None and name not in shipped:
            raise ConfigurationError(
                f"RobotKind: unknown shipped kind {name!r}; shipped: {', '.join(shipped)}"
                " (a new kind gives its kernel, 'module:function')",
                argument="name",
            )
        self.kernel = kernel or shipped[name]
        if kernel is not None:
            _check_kernel(name, kernel)
        try:
            known = robot_kinds.register(name, self.kernel)
        except ValueError as exc:
            raise ConfigurationError(f"RobotKind: {exc}", argument="name") from None
        if not known:
            warnings.warn(
                f"robot kind {name!r} declared after the compiled kinematics were generated:"
                " its robots run on the object path in this process (import its module"
                " before the first compiled step)",
                RuntimeWarning,
                stacklevel=2,
            )

    @property
    def code(self) -> int | None:
        """The kind's code, None when it has none in this process (class docstring)."""
        return robot_kinds.code(self.name)

    def pack(
        self,
        eMc: ArrayLike,
        cVe: ArrayLike,
        *,
        scalars: ArrayLike = (),
        table: ArrayLike | None = None,
        frames: ArrayLike | None = None,
    ) -> RobotPack | None:
        """The pack of a robot of this kind (module docstring), or None when the kind has
        no code in this process. ``eMc`` (4, 4; m), ``cVe`` (6, 6); ``scalars``, ``table``
        and ``frames`` as the kind's kernel reads them (empty when not given)."""
        code = self.code
        if code is None:
            return None

        parts = (eMc, cVe, scalars, table, frames)
        names = ("eMc", "cVe", "scalars", "table", "frames")
        return (code, *(_part(a, k, d) for a, k, d in zip(parts, names, (2, 2, 1, 2, 3))))

    def __repr__(self) -> str:
        return f"RobotKind({self.name!r}, {self.kernel!r})"


def _part(a: ArrayLike | None, name: str, ndim: int) -> Any:
    """One part of a pack: a C-contiguous float64 array of ``ndim`` dimensions."""
    if a is None:
        return np.zeros((0,) * ndim)
    out = np.ascontiguousarray(a, dtype=np.float64)
    if out.ndim != ndim:
        raise ConfigurationError(
            f"RobotKind.pack: {name} has {out.ndim} dimension(s), expected {ndim}",
            argument=name,
        )
    return out


def _check_kernel(name: str, kernel: str) -> None:
    """The kernel ``"module:function"`` of a declared kind exists (its module imported)."""
    module, _, func = kernel.partition(":")
    if not module or not func.isidentifier():
        raise ConfigurationError(
            f"RobotKind {name!r}: kernel {kernel!r} is not 'module:function'", argument="kernel"
        )
    try:
        found = callable(getattr(importlib.import_module(module), func))
    except (ImportError, AttributeError):
        found = False
    if not found:
        raise ConfigurationError(
            f"RobotKind {name!r}: no kernel {kernel!r} (define the kernel before the declaration)",
            argument="kernel",
        )
