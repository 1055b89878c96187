"""The tallies of the robustness sweep: per check and factor, the set-ups it holds in, its
95 % Wilson interval and its category (:mod:`redservo.reproduction.robustness` explains the
categories and the factors)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from redservo.campaign.stats import wilson_interval
from redservo.reproduction.base import ExperimentSpec
from redservo.reproduction.checks import Kind
from redservo.reproduction.perturbation import FACTORS
from redservo.reproduction.unfiltered import FACTOR as UNFILTERED

__all__ = [
    "CATEGORIES",
    "ROBUST_LEVEL",
    "CheckRobustness",
    "Robustness",
    "SetupResult",
    "aggregate",
    "categorize",
]

ROBUST_LEVEL = 0.7
"""The level the 95 % Wilson interval is compared with (module docstring)."""
COMBINED = ("all", UNFILTERED)
"""Columns that are not a single factor (never named as the one that breaks a claim)."""
Category = Literal["robust", "inconclusive", "fragile", "not reproduced"]
CATEGORIES: tuple[Category, ...] = ("robust", "inconclusive", "fragile", "not reproduced")


def categorize(nominal: bool | None, interval: tuple[float, float]) -> Category:
    """The category of a claim from its nominal verdict and 95 % interval (module docstring)."""
    if nominal is False:
        return "not reproduced"
    lo, hi = interval
    if lo >= ROBUST_LEVEL:
        return "robust"
    return "fragile" if hi < ROBUST_LEVEL else "inconclusive"


@dataclass
class SetupResult:
    """One experiment on one perturbed set-up.

    Attributes:
        experiment: Experiment id.
        index: Set-up number.
        perturbation: The set-up drawn (``Perturbation.to_dict()``), None if none was valid.
        verdicts: ``{check name: holds}``.
        seconds: Wall time of the set-up in its worker.
        error: Why the set-up could not be run, or "".
        factor: The factor perturbed (``"all"``: every one).
    """

    experiment: str
    index: int
    perturbation: dict[str, Any] | None
    verdicts: dict[str, bool]
    seconds: float
    error: str = ""
    factor: str = "all"


@dataclass
class CheckRobustness:
    """How one check fares over the perturbed set-ups.

    Attributes:
        experiment: Experiment id.
        name: Check name.
        text: The statement.
        kind: Paper claim or implementation check.
        nominal: The verdict on the nominal set-up (None if the nominal run was not made).
        by_factor: ``{factor: (holds, n)}``, in :data:`FACTORS` order.
        by_period: ``{period in ms: [holds, n]}`` over the all-factors set-ups.
        failing: ``{factor: [indices of the set-ups where it does not hold]}``.
    """

    experiment: str
    name: str
    text: str
    kind: Kind
    nominal: bool | None
    by_factor: dict[str, tuple[int, int]]
    by_period: dict[str, list[int]] = field(default_factory=dict)
    failing: dict[str, list[int]] = field(default_factory=dict)

    @property
    def holds(self) -> int:
        """Set-ups it holds in, all factors together."""
        return self.by_factor.get("all", (0, 0))[0]

    @property
    def n(self) -> int:
        return self.by_factor.get("all", (0, 0))[1]

    @property
    def fraction(self) -> float:
        return self.holds / self.n if self.n else 0.0

    @property
    def interval(self) -> tuple[float, float]:
        return self.interval_of("all")

    def interval_of(self, factor: str) -> tuple[float, float]:
        k, n = self.by_factor.get(factor, (0, 0))
        return wilson_interval(k, n) if n else (0.0, 1.0)

    @property
    def category(self) -> Category:
        return categorize(self.nominal, self.interval)

    @property
    def breaking(self) -> list[str]:
        """The single factors whose interval lies wholly below ``ROBUST_LEVEL``."""
        return [
            f
            for f, (_, n) in self.by_factor.items()
            if f not in COMBINED and n and self.interval_of(f)[1] < ROBUST_LEVEL
        ]

    @property
    def weakest(self) -> str | None:
        """The single factor it holds least often under (None if it always holds)."""
        rates = {f: k / n for f, (k, n) in self.by_factor.items() if f not in COMBINED and n}
        if not rates or min(rates.values()) >= 1.0:
            return None
        return min(rates, key=lambda f: rates[f])

    def to_dict(self) -> dict[str, Any]:
        return {
            "experiment": self.experiment,
            "name": self.name,
            "claim": self.text,
            "kind": self.kind,
            "nominal": self.nominal,
            "holds": self.holds,
            "n": self.n,
            "fraction": self.fraction,
            "interval": list(self.interval),
            "category": self.category,
            "by_factor": {
                f: {"holds": k, "n": n, "interval": list(self.interval_of(f))}
                for f, (k, n) in self.by_factor.items()
            },
            "broken_by": self.breaking,
            "weakest_factor": self.weakest,
            "by_period_ms": self.by_period,
            "failing_setups": self.failing,
        }


@dataclass
class Robustness:
    """The sweep's results: per check, and per set-up.

    Attributes:
        n: Set-ups per experiment and factor.
        seed: Seed of the draws.
        fast: Whether the quick experiments were used (the period is then not perturbed).
        pixel_noise: Whether the image sensor measured the features (image factors swept).
        workers: Processes used.
        seconds: Wall time of the sweep.
        checks: One entry per check of every experiment, in report order.
        setups: Every set-up run.
        factors: The factors swept, in report order (``"unfiltered"`` last when drawn).
        unfiltered: Unfiltered set-ups per experiment (:mod:`redservo.reproduction.unfiltered`).
    """

    n: int
    seed: int
    fast: bool
    pixel_noise: bool
    workers: int
    seconds: float
    checks: list[CheckRobustness]
    setups: list[SetupResult]
    factors: tuple[str, ...] = FACTORS
    unfiltered: int = 0

    def by_category(self, kind: Kind | None = None) -> dict[Category, list[CheckRobustness]]:
        """``{category: [checks]}`` (only ``kind`` when given), in report order."""
        out: dict[Category, list[CheckRobustness]] = {c: [] for c in CATEGORIES}
        for c in self.checks:
            if kind is None or c.kind == kind:
                out[c.category].append(c)
        return out

    def get(self, experiment: str, name: str) -> CheckRobustness | None:
        for c in self.checks:
            if c.experiment == experiment and c.name == name:
                return c
        return None

    def to_dict(self) -> dict[str, Any]:
        return {
            "n": self.n,
            "seed": self.seed,
            "fast": self.fast,
            "pixel_noise": self.pixel_noise,
            "workers": self.workers,
            "seconds": self.seconds,
            "factors": list(self.factors),
            "unfiltered": self.unfiltered,
            "robust_level": ROBUST_LEVEL,
            "checks": [c.to_dict() for c in self.checks],
            "setups": [s.__dict__ for s in self.setups],
        }


def aggregate(
    specs: Sequence[ExperimentSpec],
    setups: list[SetupResult],
    nominal: Mapping[tuple[str, str], bool],
    factors: Sequence[str] = FACTORS,
) -> list[CheckRobustness]:
    out: list[CheckRobustness] = []
    for spec in specs:
        mine = sorted((s for s in setups if s.experiment == spec.id), key=lambda s: s.index)
        for check in spec.checks:
            by_factor: dict[str, tuple[int, int]] = {}
            failing: dict[str, list[int]] = {}
            by_period: dict[str, list[int]] = {}
            for factor in factors:
                rows = [s for s in mine if s.factor == factor]
                if not rows:
                    continue
                ok = [s.verdicts.get(check.name, False) for s in rows]
                by_factor[factor] = (sum(ok), len(ok))
                failing[factor] = [s.index for s, v in zip(rows, ok, strict=True) if not v]
                if factor != "all":
                    continue
                for s, v in zip(rows, ok, strict=True):
                    per = s.perturbation.get("period") if s.perturbation else None
                    tally = by_period.setdefault(
                        "nominal" if per is None else f"{per * 1e3:.0f}", [0, 0]
                    )
                    tally[0] += int(v)
                    tally[1] += 1
            out.append(
                CheckRobustness(
                    spec.id,
                    check.name,
                    check.text,
                    check.kind,
                    nominal.get((spec.id, check.name)),
                    by_factor,
                    by_period,
                    failing,
                )
            )
    return out
