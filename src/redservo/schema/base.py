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
)
from pydantic_core import PydanticCustomError, PydanticUndefined, core_schema

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
