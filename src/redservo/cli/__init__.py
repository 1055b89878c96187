"""The ``redservo`` command line: the parser, one module per command group.

:func:`main` (:mod:`redservo.cli.entry`) is the console script's entry point,
``redservo.cli:main``, imported on first use so that importing a command group does not load
the whole command line."""

from __future__ import annotations

from typing import Any

__all__ = ["main"]


def __getattr__(name: str) -> Any:
    if name == "main":
        from redservo.cli.entry import main

        return main
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
