"""The reproduction framework: experiments, runs, figures and claims checked by code.

An :class:`ExperimentSpec` names a shipped scenario, the runs to make on it
(method, law options, option overrides), a function that draws the paper's
figures and a function that turns the logs into :class:`Claim` verdicts.
Claims are computed from the logs, never written by hand; each carries the
numbers it was decided from.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from redservo.experiment import Experiment, build
from redservo.scenario import apply_overrides, load_scenario
from redservo.simulation import SimulationResult

__all__ = [
    "PAPER_EXACT",
    "WIDE_LIMIT",
    "Claim",
    "ExperimentSpec",
    "RunSpec",
    "Runs",
    "run_experiment",
    "without_limits",
]

PAPER_EXACT: Mapping[str, Any] = {"shield": False, "robust": False}
"""The reproductions run the papers' laws exactly as printed: no position shield, no robust
inverse, no velocity or acceleration limits (the papers' figures show the crossings and the
transients that the safety layer would remove; docs/safety.md)."""

WIDE_LIMIT = 5.0
"""Half-width (m or rad) of the limits of a reference run 'without limits'."""


def without_limits(n: int, wide: float = WIDE_LIMIT) -> tuple[str, ...]:
    """Overrides that move every joint limit of an n-joint robot to ±``wide``.

    A ``classical`` run with them is the reference "what the task alone asks for" that the
    cylinder and MC05 experiments compare the avoidance with.
    """
    return (
        "robot.q_min=[" + ", ".join([f"{-wide}"] * n) + "]",
        "robot.q_max=[" + ", ".join([f"{wide}"] * n) + "]",
    )


@dataclass(frozen=True)
class RunSpec:
    """One run of an experiment.

    Attributes:
        label: Name used in tables, figures and claims (e.g. ``"gpm α=2"``).
        method: Law name.
        law_options: Keyword options of the law.
        overrides: ``--set``-style scenario overrides applied for this run only.
    """

    label: str
    method: str
    law_options: Mapping[str, Any] = field(default_factory=dict)
    overrides: tuple[str, ...] = ()


@dataclass
class Claim:
    """A qualitative claim of a paper and whether the logs reproduce it.

    Attributes:
        claim: The claim's text.
        reproduced: The verdict computed from the logs.
        evidence: The numbers the verdict was computed from.
        note: Why, when it is not reproduced (or any caveat).
    """

    claim: str
    reproduced: bool
    evidence: dict[str, Any]
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "claim": self.claim,
            "reproduced": bool(self.reproduced),
            "evidence": self.evidence,
            "note": self.note,
        }


@dataclass
class Runs:
    """The results of an experiment's runs, by label, and the experiments they ran on."""

    results: dict[str, SimulationResult]
    experiments: dict[str, Experiment]

    def __getitem__(self, label: str) -> SimulationResult:
        return self.results[label]

    @property
    def base(self) -> Experiment:
        """The experiment built from the unmodified scenario."""
        return next(iter(self.experiments.values()))


@dataclass(frozen=True)
class ExperimentSpec:
    """One experiment of a paper.

    Attributes:
        id: Short identifier (``--only ID``).
        title: Section title in the report.
        paper: Reference (paper, section, figures).
        scenario: Shipped scenario name.
        runs: The runs to make.
        figures: ``f(runs, out_dir) -> [paths]`` draws the paper's figures.
        claims: ``f(runs) -> [Claim]`` checks the paper's claims on the logs.
        fast: Scenario overrides for the quick version (tests).
        notes: How the scenario was chosen, shown in the report.
    """

    id: str
    title: str
    paper: str
    scenario: str
    runs: tuple[RunSpec, ...]
    figures: Callable[[Runs, Path], list[Path]]
    claims: Callable[[Runs], list[Claim]]
    fast: tuple[str, ...] = ()
    notes: str = ""


def run_experiment(
    spec: ExperimentSpec,
    *,
    fast: bool = False,
    progress: Callable[[str], None] | None = None,
) -> Runs:
    """Run every run of ``spec`` (the quick version with ``fast=True``)."""
    base = load_scenario(spec.scenario)
    if fast and spec.fast:
        base = apply_overrides(base, list(spec.fast))
    built: dict[tuple[str, ...], Experiment] = {}
    results: dict[str, SimulationResult] = {}
    experiments: dict[str, Experiment] = {}
    for run in spec.runs:
        if run.overrides not in built:
            sc = apply_overrides(base, list(run.overrides)) if run.overrides else base
            exp = build(sc)
            exp.limits = exp.limits.without_rates()  # the papers' robots: position limits only
            built[run.overrides] = exp
        exp = built[run.overrides]
        if progress is not None:
            progress(f"{spec.id}: {run.label}")
        options = {**PAPER_EXACT, **run.law_options}
        results[run.label] = exp.run(method=run.method, law_options=options)
        experiments[run.label] = exp
    return Runs(results, experiments)
