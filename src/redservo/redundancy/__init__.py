"""Control laws: one module per method family, all behind :func:`make_law`.

Importing this package registers every law. :data:`METHODS` lists their names
in a stable order (the seed papers' methods first, then the baselines).
"""

from __future__ import annotations

import importlib
from typing import Any

from redservo.kernels import law_table
from redservo.redundancy.base import (
    Diagnostics,
    Law,
    LawResult,
    law_class,
    make_law,
    register,
    registered_methods,
)

__all__ = [
    "METHODS",
    "METHOD_DESCRIPTIONS",
    "Diagnostics",
    "Law",
    "LawResult",
    "law_class",
    "make_law",
    "register",
]

# Modules that register laws, in the order their methods are listed.
_MODULES = (
    "classical",
    "gpm",
    "iterative",
    "directional",
    "wln",
    "sns",
    "qp",
    "qp_goal",
    "large_projection",
    "predictive",
)
for _mod in _MODULES:
    importlib.import_module(f"redservo.redundancy.{_mod}")

from redservo.redundancy.declare import bound_laws  # noqa: E402 - after the laws' modules

law_table.provide(lambda: bound_laws(registered_methods()))
"""The compiled dispatch takes the laws declaring their kernel from the registry, as it is
when the step kernel is first imported (docs/extending.md)."""

_ORDER = (
    "classical",
    "gpm",
    "gpm-auto",
    "iterative-basic",
    "iterative",
    "iterative-smooth",
    "iterative-smooth-e2",
    "directional",
    "wln",
    "sns",
    "qp",
    "qp-goal",
    "large-projection",
    "predictive",
)


def _methods() -> tuple[str, ...]:
    registered = registered_methods()
    return tuple(
        [n for n in _ORDER if n in registered] + [n for n in registered if n not in _ORDER]
    )


def __getattr__(name: str) -> Any:
    """:data:`METHODS` and :data:`METHOD_DESCRIPTIONS`, read from the registry when asked,
    so that a law registered after this import (docs/extending.md) is listed too."""
    if name == "METHODS":
        return _methods()
    if name == "METHOD_DESCRIPTIONS":
        registered = registered_methods()
        return {n: registered[n].description for n in _methods()}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


METHODS: tuple[str, ...]
"""Names accepted by :func:`make_law` (the registry now: the seed papers' methods first)."""
METHOD_DESCRIPTIONS: dict[str, str]
"""One-line description of each method."""
