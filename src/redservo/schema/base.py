"""Building blocks of the file schemas: strict tables, bounded numbers, names, one-line errors.

Every table of a scenario or campaign file is a :class:`Table` (pydantic v2, strict: a
string is never read as a number, a float never as an integer, unknown keys are refused).
A field carries its type, its allowed range, its default and its documentation (with
units) in one place; ``docs/scenarios.md`` and ``docs/campaigns.md`` are generated from
them (:mod:`redservo.schema.docs`). :func:`to_error` turns pydantic's errors into our one
line ``FILE: key 'features[1].components': what is wrong; what is allowed``.
"""

from __future__ import annotations

import difflib
import math
import types
import typing
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Annotated, Any, NoReturn

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    GetCoreSchemaHandler,
    Tag,
    ValidationError,
)
from pydantic.fields import FieldInfo
from pydantic_core import PydanticCustomError, PydanticUndefined, core_schema

from redservo.errors import ScenarioError

__all__ = [
    "BIG",
    "Doc",
    "PerJoint",
    "Table",
    "Vec3",
    "choice",
    "did_you_mean",
    "fail",
    "integer",
    "num",
    "tagged_union",
    "to_error",
    "unknown_name",
]

BIG = 1e3
"""Largest magnitude of a length (m), an angle (rad), a joint position or a gain (1/s)."""


@dataclass(frozen=True)
class Doc:
    """Metadata: how the documentation names a field's type (e.g. ``"3 numbers"``)."""

    type: str


class Table(BaseModel):
    """A strict TOML table: known keys only, no type coercion (an int is accepted as a float)."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


def num(
    default: Any = PydanticUndefined,
    *,
    description: str,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
) -> Any:
    """A finite number field with bounds (``gt``/``ge``/``lt``/``le``) and a description."""
    return Field(default, gt=gt, ge=ge, lt=lt, le=le, allow_inf_nan=False, description=description)


def integer(
    default: Any = PydanticUndefined,
    *,
    description: str,
    ge: int | None = None,
    le: int | None = None,
) -> Any:
    """An integer field with bounds and a description."""
    return Field(default, ge=ge, le=le, description=description)


def choice(default: Any = PydanticUndefined, *, what: str, description: str) -> Any:
    """A ``Literal`` field; an unknown value reads ``unknown WHAT 'x'; allowed: ...``."""
    return Field(default, description=description, json_schema_extra={"what": what})


Coord = Annotated[float, Field(ge=-BIG, le=BIG, allow_inf_nan=False)]
Vec3 = Annotated[
    list[Coord], Field(min_length=3, max_length=3), Doc("3 numbers, each in [-1000, 1000]")
]
"""Three finite numbers of magnitude at most :data:`BIG` (a position, a vector, a rotation)."""


# --------------------------------------------------------------------------- errors in validators


def fail(message: str, key: str = "") -> NoReturn:
    """Raise a validation error with our ``message``; ``key`` extends the key path."""
    raise PydanticCustomError("redservo", "{message}", {"message": message, "key": key})


def did_you_mean(value: object, allowed: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest allowed name, or an empty string."""
    close = difflib.get_close_matches(str(value), list(allowed), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def unknown_name(what: str, value: object, allowed: Sequence[str]) -> str:
    """``unknown WHAT 'x'; allowed: a, b, c (did you mean 'a'?)``."""
    shown = ", ".join(allowed) if allowed else "(none)"
    return f"unknown {what} {value!r}; allowed: {shown}{did_you_mean(value, allowed)}"


def _is_number(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


@dataclass(frozen=True)
class PerJoint:
    """Metadata: a number (same for every joint) or an array with one number per joint.

    Use as ``Annotated[float | list[float], PerJoint(gt=0.0, le=BIG, unit="rad/s")]``; every
    value must be finite, within the bounds; an error names the entry (``qdot_max[2]``).
    """

    gt: float | None = None
    ge: float | None = None
    le: float = BIG
    unit: str = ""
    doc: str = ""

    @property
    def type(self) -> str:
        """How the documentation names the type."""
        return self.doc or f"number or array (one per joint), {self._bounds()} ({self.unit})"

    def _bounds(self) -> str:
        lo = f"> {self.gt:g}" if self.gt is not None else f">= {self.ge:g}"
        return f"{lo}, <= {self.le:g}"

    def check(self, value: Any) -> float | list[float]:
        """Validate ``value``; return a float or a list of floats."""
        values = value if isinstance(value, list) else [value]
        if not values or not all(_is_number(v) for v in values):
            fail(f"expected a number or an array of numbers (one per joint), got {_show(value)}")
        for i, v in enumerate(values):
            ok = (self.gt is None or v > self.gt) and (self.ge is None or v >= self.ge)
            if not (ok and v <= self.le and math.isfinite(v)):
                where = f"[{i}]" if isinstance(value, list) else ""
                fail(f"must be finite, {self._bounds()} ({self.unit}), got {v!r}", where)
        return [float(v) for v in values] if isinstance(value, list) else float(value)

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> Any:
        return core_schema.no_info_plain_validator_function(self.check)


# --------------------------------------------------------------------------- pydantic -> one line


def _show(value: object, limit: int = 60) -> str:
    text = repr(value)
    if len(text) > limit:
        text = text[: limit - 3] + "..."
    names = {bool: "boolean", int: "integer", float: "number", str: "string", list: "array"}
    kind = names.get(type(value)) or ("table" if isinstance(value, dict) else type(value).__name__)
    return f"{kind} {text}"


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


def tagged_union(kinds: Mapping[str, type[BaseModel]], *, default: str | None, what: str) -> Any:
    """The type "one of these tables, chosen by its ``kind`` key" over a registry of kinds.

    A new kind is one more entry in the registry (``OBJECT_KINDS``, ``FEATURE_KINDS``, ...).
    An unknown kind reads ``unknown WHAT 'x'; allowed: ...``; ``default`` is the kind of a
    table without ``kind`` (None: ``kind`` is required).
    """
    members = tuple(Annotated[model, Tag(kind)] for kind, model in kinds.items())
    return Annotated[
        typing.Union[members],  # noqa: UP007 - a runtime tuple of members
        Discriminator(kind_of(default)),
        Field(json_schema_extra={"what": what}),
    ]


def kind_of(default: str | None) -> Callable[[Any], str | None]:
    """Discriminator of a tagged union: the ``kind`` key (``default`` when it is absent)."""

    def get(value: Any) -> str | None:
        if isinstance(value, dict):
            kind = value.get("kind", default)
        else:
            kind = getattr(value, "kind", None)
        return None if kind is None else str(kind)

    return get
