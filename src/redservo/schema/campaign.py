"""Schema of a campaign file (``docs/campaigns.md`` is generated from it).

:class:`CampaignSpec` checks every key, type, range and method name of the file; what
depends on the base scenario (its ``rho``, its joint names) is checked by
:func:`redservo.campaign.parse_campaign` once the scenario is loaded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import Field, GetCoreSchemaHandler, field_validator, model_validator
from pydantic_core import core_schema

from redservo.schema.base import Table, _is_number, _show, choice, fail, integer, num, unknown_name

__all__ = ["MAX_SAMPLES", "CampaignSpec", "ErrorsTable", "RangeOf", "StartTable", "TargetTable"]

MAX_SAMPLES = 1_000_000
"""Largest number of samples of a campaign."""


@dataclass(frozen=True)
class RangeOf:
    """Metadata: a range ``[lo, hi]`` given as a number or a ``[lo, hi]`` pair.

    A number ``h`` means ``[-|h|, |h|]`` when ``symmetric`` and ``[h, h]`` otherwise.
    Every value is finite and within the bounds; ``lo <= hi``.
    """

    symmetric: bool
    le: float
    gt: float | None = None
    ge: float | None = None
    unit: str = ""

    @property
    def type(self) -> str:
        """How the documentation names the type."""
        number = "±h" if self.symmetric else "a fixed value"
        return f"number ({number}) or [lo, hi], each {self._bounds()}"

    def _bounds(self) -> str:
        lo = f"> {self.gt:g}" if self.gt is not None else f">= {self.ge:g}"
        unit = f" ({self.unit})" if self.unit else ""
        return f"{lo} and <= {self.le:g}{unit}"

    def check(self, value: Any) -> tuple[float, float]:
        """Validate ``value``; return ``(lo, hi)``."""
        if _is_number(value):
            v = float(value)
            lo, hi = (-abs(v), abs(v)) if self.symmetric else (v, v)
        elif isinstance(value, list) and len(value) == 2 and all(_is_number(x) for x in value):
            lo, hi = float(value[0]), float(value[1])
        else:
            fail(f"expected a number or a [lo, hi] pair of numbers, got {_show(value)}")
        for v in (lo, hi):
            low_ok = (self.gt is None or v > self.gt) and (self.ge is None or v >= self.ge)
            if not (math.isfinite(v) and low_ok and v <= self.le):
                fail(f"each value must be finite, {self._bounds()}, got {value!r}")
        if lo > hi:
            fail(f"lo > hi in {value!r}")
        return lo, hi

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> Any:
        return core_schema.no_info_plain_validator_function(self.check)


Range = tuple[float, float]
_Move = Annotated[Range, RangeOf(symmetric=True, ge=-10.0, le=10.0, unit="m")]
_Turn = Annotated[Range, RangeOf(symmetric=True, ge=-180.0, le=180.0, unit="deg")]
_ZERO3 = ((0.0, 0.0), (0.0, 0.0), (0.0, 0.0))


class StartTable(Table):
    """Start configurations near the limits (docs/campaigns.md, "Start configurations")."""

    p_band: float = num(
        0.5, ge=0.0, le=1.0, description="probability that a joint starts in the outer band"
    )
    band_beyond: float = num(
        0.5,
        ge=0.0,
        le=4.0,
        description="the band reaches (1 + band_beyond) rho into the range; (1 + band_beyond) rho < 0.5",
    )
    min_margin: float = num(
        0.01,
        ge=0.0,
        lt=0.5,
        description="smallest start distance to a limit, fraction of the range",
    )
    min_in_band: int = integer(
        1, ge=0, le=1000, description="at least this many joints start in the band"
    )
    joints: list[str] | None = Field(
        None, min_length=1, description="joints that may start in the band (default: all)"
    )


class TargetTable(Table):
    """Random placement of the scene relative to the start camera."""

    translation: list[_Move] = Field(
        list(_ZERO3),
        min_length=3,
        max_length=3,
        description="per start-camera axis: ±h or [lo, hi] (m)",
    )
    rotation_deg: list[_Turn] = Field(
        list(_ZERO3),
        min_length=3,
        max_length=3,
        description="per reference-object axis: ±h or [lo, hi] (deg)",
    )
    image_margin_px: float = num(
        10.0, ge=0.0, le=1e4, description="the start image keeps this far from the border (px)"
    )
    motion_frame: Literal["camera", "world"] = choice(
        "camera",
        what="motion frame",
        description="object motions kept relative to the start camera or the world",
    )


class ErrorsTable(Table):
    """Noise and modelling errors, each optional (absent: the scenario's value)."""

    noise_std: (
        Annotated[Range, RangeOf(symmetric=False, ge=0.0, le=10.0, unit="feature units")] | None
    ) = Field(None, description="feature noise std: number or [lo, hi]")
    depth_scale: Annotated[Range, RangeOf(symmetric=False, gt=0.0, le=100.0, unit="")] | None = (
        Field(None, description="the controller's depth is depth_scale × Z: number or [lo, hi]")
    )
    hand_eye_translation: float = num(
        0.0, ge=0.0, le=1.0, description="± per axis of the hand-eye error (m)"
    )
    hand_eye_rotation_deg: float = num(
        0.0, ge=0.0, le=180.0, description="± per rotation-vector component (deg)"
    )


class CampaignSpec(Table):
    """A campaign file."""

    name: str | None = Field(None, max_length=200, description="default: the file name")
    description: str = Field("", max_length=2000, description="one line")
    scenario: str = Field(
        min_length=1, description="a shipped scenario name, or a .toml path relative to this file"
    )
    samples: int = integer(100, ge=1, le=MAX_SAMPLES, description="default number of samples N")
    methods: list[str] | None = Field(
        None, min_length=1, description="default methods (default: all)"
    )
    max_attempts: int = integer(
        100, ge=1, le=10_000, description="draws per sample before giving up"
    )
    overrides: dict[str, Any] = Field({}, description="deep-merged into the base scenario")
    method_options: dict[str, dict[str, Any]] = Field({}, description="law options per method")
    start: StartTable = Field(
        default_factory=lambda: StartTable.model_validate({}), description="start configurations"
    )
    target: TargetTable = Field(
        default_factory=lambda: TargetTable.model_validate({}), description="target placement"
    )
    errors: ErrorsTable = Field(
        default_factory=lambda: ErrorsTable.model_validate({}),
        description="noise and modelling errors",
    )

    @field_validator("methods")
    @classmethod
    def _known_methods(cls, v: list[str] | None) -> list[str] | None:
        from redservo.redundancy import METHODS

        values = v or []
        for i, m in enumerate(values):
            if m not in METHODS:
                fail(unknown_name("method", m, METHODS), f"[{i}]")
            if m in values[:i]:
                fail(f"a method is listed twice: {m!r}", f"[{i}]")
        return v

    @model_validator(mode="after")
    def _options(self) -> CampaignSpec:
        from redservo.errors import RedservoError
        from redservo.redundancy import METHODS, make_law

        for m, opts in self.method_options.items():
            if m not in METHODS:
                fail(unknown_name("method", m, METHODS), f"method_options.{m}")
            try:
                make_law(m, **opts)
            except RedservoError as exc:
                arg = getattr(exc, "argument", None)
                fail(str(exc), f"method_options.{m}" + (f".{arg}" if arg in opts else ""))
        return self
