"""The robot kinds of the compiled engine, by code (no numba: importing is free).

A robot kind is a name and its kinematics kernel, ``"module:function"`` with the
signature ``kernel(q, eMc, cVe, scalars, table, frames) -> (bMc, J)``: the camera pose
(4, 4; m) and ``J = cVe eJe`` (6, n) at ``q`` (n,; rad or m), from the parts of the robot
pack (:mod:`redservo.robots.pack`). Its code is its place in :func:`kinds`: the shipped
kinds first (:data:`SHIPPED`, the one registry line of a shipped kind), then the kinds
declared outside the package (:class:`redservo.robots.pack.RobotKind`), in declaration
order. :mod:`redservo.kernels.robot` generates the compiled dispatch from this table when
it is first imported (:func:`freeze`); a kind declared later has no code in that process.
"""

from __future__ import annotations

__all__ = ["SHIPPED", "code", "freeze", "frozen", "kinds", "register"]

SHIPPED: tuple[tuple[str, str], ...] = (
    ("afma6", "redservo.kernels.kinematics:afma6_robot"),
    ("dh", "redservo.kernels.kinematics:dh_robot"),
    ("chain", "redservo.kernels.chain:chain_robot"),
)
"""The shipped kinds, ``(name, kernel)``: codes 0 (the Afma6), 1 (a Denavit–Hartenberg
chain) and 2 (fixed transforms and joint axes: every URDF and MJCF robot)."""

_KINDS: dict[str, str] = dict(SHIPPED)
_FROZEN: list[int] = []


def register(name: str, kernel: str) -> bool:
    """Add the kind ``name`` with its kernel ``"module:function"``; False when the table
    was already frozen (the kind then has no code in this process). Registering a kind
    again with the same kernel is a no-op; a different kernel raises ValueError."""
    known = _KINDS.get(name)
    if known is not None and known != kernel:
        raise ValueError(f"robot kind {name!r} is already declared with kernel {known!r}")
    if known is None and not _FROZEN:
        _KINDS[name] = kernel
    return code(name) is not None


def kinds() -> list[tuple[str, str]]:
    """``(name, kernel)`` of every kind, in code order (frozen or not)."""
    return list(_KINDS.items())[: _FROZEN[0] if _FROZEN else None]


def code(name: str) -> int | None:
    """The code of the kind ``name``, None when it has none (unknown, or declared after
    the dispatch was generated)."""
    names = [k for k, _ in kinds()]
    return names.index(name) if name in names else None


def freeze() -> list[tuple[str, str]]:
    """Fix the table (the generated dispatch knows these kinds) and return it."""
    if not _FROZEN:
        _FROZEN.append(len(_KINDS))
    return kinds()


def frozen() -> bool:
    """True once the compiled dispatch was generated."""
    return bool(_FROZEN)
