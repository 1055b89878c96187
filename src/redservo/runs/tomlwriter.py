"""A small TOML writer for the values scenario and campaign files hold.

The standard library reads TOML (:mod:`tomllib`) but does not write it. Scenario tables
hold only strings, booleans, integers, floats, arrays and tables, so a few dozen lines
suffice (no ``tomli_w`` dependency). :func:`dumps` writes top-level scalars first, then
one ``[table]`` per table and one ``[[table]]`` per entry of an array of tables; deeper
tables are written as inline tables. Floats are written with Python's shortest
round-trip ``repr``, so ``tomllib.loads(dumps(t)) == t`` holds for every such table.
``None`` values are left out (TOML has no null).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from redservo.errors import ConfigurationError

__all__ = ["dumps"]

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _key(key: str) -> str:
    if not isinstance(key, str):
        raise ConfigurationError(f"TOML keys must be strings, got {key!r}", argument="table")
    return key if _BARE_KEY.fullmatch(key) else json.dumps(key, ensure_ascii=False)


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as Python values; tuples as lists."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, tuple):
        return list(value)
    return value


def _value(value: Any) -> str:
    """One TOML value (scalars, arrays, inline tables)."""
    value = _plain(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        text = repr(value)
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, Mapping):
        items = [f"{_key(k)} = {_value(v)}" for k, v in value.items() if v is not None]
        return "{ " + ", ".join(items) + " }" if items else "{}"
    if isinstance(value, Sequence):
        if any(_plain(v) is None for v in value):
            raise ConfigurationError("a TOML array cannot hold None", argument="table")
        return "[" + ", ".join(_value(v) for v in value) + "]"
    raise ConfigurationError(
        f"cannot write a {type(value).__name__} as TOML: {value!r:.60}", argument="table"
    )


def _is_table_array(value: Any) -> bool:
    value = _plain(value)
    return isinstance(value, list) and bool(value) and all(isinstance(v, Mapping) for v in value)


def _section(header: str, table: Mapping[str, Any]) -> list[str]:
    return [header, *(f"{_key(k)} = {_value(v)}" for k, v in table.items() if v is not None)]


def dumps(table: Mapping[str, Any], *, header: str = "") -> str:
    """Return ``table`` as TOML text.

    Args:
        table: Nested mappings of strings, booleans, integers, floats and arrays (numpy
            scalars and arrays are accepted; ``None`` values are left out).
        header: Comment lines put at the top (each line gets a ``# `` prefix).

    Raises:
        ConfigurationError: a value TOML cannot represent (e.g. None inside an array).
    """
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    scalars = {
        k: v
        for k, v in table.items()
        if v is not None and not isinstance(v, Mapping) and not _is_table_array(v)
    }
    lines += [f"{_key(k)} = {_value(v)}" for k, v in scalars.items()]
    for k, v in table.items():
        if isinstance(v, Mapping):
            lines += ["", *_section(f"[{_key(k)}]", v)]
        elif _is_table_array(v):
            for entry in _plain(v):
                lines += ["", *_section(f"[[{_key(k)}]]", entry)]
    return "\n".join(lines).lstrip("\n") + "\n"
