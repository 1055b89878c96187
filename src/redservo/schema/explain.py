"""Pydantic's validation errors, explained in our one line.

:func:`validate` checks a file's data against its schema model; on failure :func:`to_error`
walks the model to the failing key and writes ``FILE: key 'features[1].components': what is
wrong; what is allowed`` as a :class:`~redservo.errors.ScenarioError` (the field's type,
bounds and allowed names come from the model itself, :mod:`redservo.schema.base`).
"""

from __future__ import annotations

import types
import typing
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Any

from pydantic import BaseModel, Tag, ValidationError
from pydantic.fields import FieldInfo

from redservo.errors import ScenarioError
from redservo.schema.base import _show, did_you_mean, unknown_name

__all__ = ["to_error", "validate"]


def _unwrap(tp: Any) -> Any:
    """Strip ``Annotated`` and ``| None`` until the type stops changing."""
    while True:
        origin = typing.get_origin(tp)
        if origin is Annotated:
            tp = typing.get_args(tp)[0]
            continue
        if origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            if len(args) == 1:
                tp = args[0]
                continue
        return tp


def _tagged(tp: Any) -> dict[str, Any]:
    """``{tag: member}`` of a discriminated union (members annotated with :class:`Tag`)."""
    out: dict[str, Any] = {}
    for arg in typing.get_args(tp):
        if typing.get_origin(arg) is Annotated:
            inner, *meta = typing.get_args(arg)
            for m in meta:
                if isinstance(m, Tag):
                    out[m.tag] = inner
    return out


@dataclass
class _Where:
    key: str = ""
    field: FieldInfo | None = None
    table: type[BaseModel] | None = None
    type: Any = None


def _walk(root: type[BaseModel], loc: Sequence[int | str]) -> _Where:
    """Follow pydantic's error location through the model: our key path and the last field."""
    where = _Where()
    tp: Any = root
    for item in loc:
        tp = _unwrap(tp)
        origin = typing.get_origin(tp)
        if isinstance(item, int):
            where.key += f"[{item}]"
            tp = typing.get_args(tp)[0] if origin is list else Any
            continue
        tags = _tagged(tp) if origin in (typing.Union, types.UnionType) else {}
        if item in tags:  # the union member pydantic chose: not a key of the file
            tp = tags[item]
            continue
        where.key = f"{where.key}.{item}" if where.key else item
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            where.table = tp
            where.field = tp.model_fields.get(item)
            tp = where.field.annotation if where.field is not None else Any
            if where.field is not None and where.field.metadata:
                tp = Annotated.__class_getitem__((tp, *where.field.metadata))  # type: ignore[attr-defined]
        elif origin is dict:
            tp = typing.get_args(tp)[1]
        else:
            tp = Any
    where.type = tp
    return where


_EXPECTED = {
    "float_type": "a number",
    "int_type": "an integer",
    "bool_type": "true or false",
    "string_type": "a string",
    "list_type": "an array",
    "dict_type": "a table",
    "model_type": "a table",
    "model_attributes_type": "a table",
    "literal_error": "",
}
_BOUNDS = {
    "greater_than": ">",
    "greater_than_equal": ">=",
    "less_than": "<",
    "less_than_equal": "<=",
}


def _what_of(tp: Any) -> str | None:
    """The ``what`` of the innermost ``Field(json_schema_extra={"what": ...})`` on ``tp``."""
    origin = typing.get_origin(tp)
    if origin is Annotated:
        inner, *meta = typing.get_args(tp)
        for m in meta:
            extra = m.json_schema_extra if isinstance(m, FieldInfo) else None
            if isinstance(extra, dict) and "what" in extra:
                return str(extra["what"])
        return _what_of(inner)
    if origin in (typing.Union, types.UnionType):
        for arg in typing.get_args(tp):
            found = _what_of(arg) if arg is not type(None) else None
            if found:
                return found
    return None


def _what(where: _Where) -> str:
    found = _what_of(where.type)
    if found:
        return found
    extra = where.field.json_schema_extra if where.field is not None else None
    return str(extra.get("what", "value")) if isinstance(extra, dict) else "value"


def _message(err: Any, where: _Where) -> tuple[str, str]:
    """Return ``(key suffix, message)`` for one pydantic error."""
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    if kind == "redservo":
        return str(ctx.get("key", "")), str(ctx["message"])
    if kind == "missing":
        return "", "missing required key"
    if kind == "extra_forbidden":
        allowed = sorted(where.table.model_fields) if where.table is not None else []
        name = where.key.rsplit(".", 1)[-1]
        renamed = getattr(where.table, "RENAMED", {}).get(name)
        if renamed is not None:
            return "", f"renamed: write {renamed[0]} ({renamed[1]})"
        return "", f"unknown key; allowed here: {', '.join(allowed)}{did_you_mean(name, allowed)}"
    if kind == "literal_error":
        allowed = (
            [str(v) for v in typing.get_args(_unwrap(where.field.annotation))]
            if where.field
            else []
        )
        if isinstance(value, str):
            return "", unknown_name(_what(where), value, allowed)
        return "", f"expected one of {', '.join(allowed)}, got {_show(value)}"
    if kind == "union_tag_invalid":
        allowed = [t.strip(" '") for t in str(ctx.get("expected_tags", "")).split(",")]
        return ".kind", unknown_name(_what(where), ctx.get("tag"), allowed)
    if kind == "union_tag_not_found":
        if not isinstance(value, dict):
            return "", f"expected a table, got {_show(value)}"
        return ".kind", "missing required key"
    if kind in _EXPECTED:
        return "", f"expected {_EXPECTED[kind]}, got {_show(value)}"
    if kind in _BOUNDS:
        bound = next(iter(ctx.values()))
        shown = str(bound) if isinstance(bound, int) else f"{bound:g}"
        return "", f"must be {_BOUNDS[kind]} {shown}, got {value!r}"
    if kind == "finite_number":
        return "", f"must be a finite number, got {value!r}"
    if kind in ("too_short", "too_long"):
        lo, hi = _length_bounds(where.type)
        want = (
            f"exactly {lo}"
            if lo is not None and lo == hi
            else (f"at least {lo}" if kind == "too_short" else f"at most {hi}")
        )
        noun = "entry" if want.endswith(" 1") else "entries"
        return "", f"expected {want} {noun}, got {ctx.get('actual_length', '?')}"
    return "", str(err["msg"]).removeprefix("Value error, ")


def _metadata(tp: Any) -> list[Any]:
    """Every metadata object of an ``Annotated`` type, also under ``| None`` (field infos
    flattened)."""
    out: list[Any] = []
    while True:
        origin = typing.get_origin(tp)
        if origin is Annotated:
            tp, *meta = typing.get_args(tp)
            for m in meta:
                out.extend(m.metadata if isinstance(m, FieldInfo) else [m])
        elif origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            if len(args) != 1:
                return out
            tp = args[0]
        else:
            return out


def _length_bounds(tp: Any) -> tuple[int | None, int | None]:
    lo = hi = None
    for m in _metadata(tp):
        lo = getattr(m, "min_length", lo)
        hi = getattr(m, "max_length", hi)
    return lo, hi


def to_error(
    exc: ValidationError, root: type[BaseModel], source: str, key_prefix: str = ""
) -> ScenarioError:
    """The first error of ``exc`` as our one-line :class:`ScenarioError` (file, key, allowed).

    ``key_prefix`` is put before the key path (e.g. ``overrides.`` for a campaign's
    overrides of its base scenario).
    """
    errors = exc.errors(include_url=False)
    err = errors[0]
    where = _walk(root, err["loc"])
    suffix, message = _message(err, where)
    key = where.key + (suffix if not suffix or suffix.startswith(("[", ".")) else f".{suffix}")
    key = (key_prefix + key.lstrip(".")).strip(".")
    more = f" (and {len(errors) - 1} more problem(s))" if len(errors) > 1 else ""
    text = f"{source}: key '{key}': {message}{more}" if key else f"{source}: {message}{more}"
    return ScenarioError(text, argument=key or None)


def validate(model: type[BaseModel], data: Any, source: str, key_prefix: str = "") -> Any:
    """Validate ``data`` against ``model``; raise our one-line :class:`ScenarioError`."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise to_error(exc, model, source, key_prefix) from None
