"""Scenario overrides given from Python: a dict ``{"control.lam": 0.8}`` or the command line's
``["control.lam=0.8"]`` strings (``--set``), turned into the assignments
:func:`redservo.scenario.apply_overrides` reads (values written as TOML)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from redservo.errors import ConfigurationError

__all__ = ["Overrides", "as_assignments"]

Overrides = Mapping[str, Any] | Sequence[str] | None
"""Scenario overrides: ``{"control.lam": 0.8, "features[0].variant": "paper"}``, or the
command line's ``["control.lam=0.8"]`` strings (``--set``); None: none."""


def as_assignments(overrides: Overrides) -> list[str]:
    """``key=value`` strings of ``overrides`` (values as TOML).

    Raises:
        ConfigurationError: a bare string (give a dict or a list of strings), or a value
            TOML cannot hold (names ``overrides``).
    """
    if overrides is None:
        return []
    if isinstance(overrides, str):
        raise ConfigurationError(
            f"overrides: give a dict or a list of 'key=value' strings, got the string "
            f"{overrides!r}",
            argument="overrides",
        )
    if isinstance(overrides, Mapping):
        from redservo.runs.tomlwriter import _value

        return [f"{key}={_value(value)}" for key, value in overrides.items()]
    return [str(item) for item in overrides]
