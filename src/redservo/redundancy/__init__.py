"""Control laws: one module per method family, all behind :func:`make_law`.

Importing this package registers every law. :data:`METHODS` lists their names
in a stable order (the seed papers' methods first, then the baselines).
"""

from __future__ import annotations

import importlib

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
    "large_projection",
    "predictive",
)
for _mod in _MODULES:
    importlib.import_module(f"redservo.redundancy.{_mod}")

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
    "large-projection",
    "predictive",
)
_registered = registered_methods()
METHODS: tuple[str, ...] = tuple(
    [n for n in _ORDER if n in _registered] + [n for n in _registered if n not in _ORDER]
)
"""Names accepted by :func:`make_law`."""

METHOD_DESCRIPTIONS: dict[str, str] = {n: _registered[n].description for n in METHODS}
"""One-line description of each method."""
