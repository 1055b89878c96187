"""The laws' declarations as the generated dispatch takes them (no numba: importing is free).

:mod:`redservo.kernels.law_dispatch` generates the compiled dispatch from
:func:`bound_laws`: each declared law with its kernel and its events kernel (the compiled
functions) and their arguments already written as expressions of the dispatch's names
(``fopt[2]``, ``(iopt[3] != 0)``, ``iout[5]``). The layer that knows the laws,
:mod:`redservo.redundancy.declare`, binds them from the declarations (``KERNEL``, option
slots) and provides them here (:func:`provide`) when it is imported; the kernels import
nothing above them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

__all__ = ["BoundLaw", "bound_laws", "provide"]


class BoundLaw(NamedTuple):
    """One declared law, bound (module docstring)."""

    method: str
    """Its name (``Law.name``)."""
    kernel: Callable[..., Any]
    """Its law kernel."""
    args: str
    """The kernel's arguments, comma-separated expressions of ``raw_law``'s names."""
    events: Callable[..., Any]
    """Its events kernel."""
    event_args: str
    """The events kernel's arguments, expressions of ``law_events``'s names."""
    outputs: Mapping[str, tuple[str, int]]
    """Its named outputs, ``name -> ("i" | "f", index)`` (the common ones included)."""
    stamp: bytes
    """The source of its kernels declared outside ``redservo/kernels/`` (cache stamp)."""


_PROVIDER: list[Callable[[], list[BoundLaw]]] = []


def provide(laws: Callable[[], list[BoundLaw]]) -> None:
    """Set the function returning the bound laws, in registration order."""
    _PROVIDER[:] = [laws]


def bound_laws() -> list[BoundLaw]:
    """The bound laws (:func:`provide`); none when no law layer is imported."""
    return _PROVIDER[0]() if _PROVIDER else []
