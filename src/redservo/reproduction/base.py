"""The reproduction framework: experiments, their runs, figures and checks.

An :class:`ExperimentSpec` names a shipped scenario (optionally with overrides), the runs
to make on it (method, law options, scenario overrides, a set-up hook), a function that
draws the paper's figures and the :class:`~redservo.reproduction.checks.Check` objects
that turn the logs into verdicts. Verdicts are computed from the logs, never written by
hand; each carries the numbers it was decided from.

Every run uses the papers' laws exactly (:data:`PAPER_EXACT`) on a robot with position
limits only (``JointLimits.without_rates``); docs/safety.md explains why the safety layer
is off here. :func:`run_experiment` also runs an experiment on a perturbed set-up
(:mod:`redservo.reproduction.perturbation`) for the robustness sweep.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from redservo.errors import ConfigurationError
from redservo.experiment.build import Experiment, build
from redservo.reproduction.checks import Check, Claim, evaluate
from redservo.scenario import Scenario, apply_overrides, load_scenario
from redservo.simulation import SimulationResult

if TYPE_CHECKING:
    from redservo.reproduction.perturbation import Perturbation
    from redservo.sensors import Sensor

__all__ = [
    "PAPER_EXACT",
    "WIDE_LIMIT",
    "Claim",
    "ExperimentSpec",
    "RunSpec",
    "Runs",
    "nominal_scenario",
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
        label: Name used in tables, figures and claims (e.g. ``"gpm alpha=2"``).
        method: Law name.
        law_options: Keyword options of the law.
        overrides: ``--set``-style scenario overrides applied for this run only.
        setup: ``f(experiment)`` applied to this run's copy of the built experiment
            (e.g. set an actuator model or replace the task); a module-level function,
            so that the robustness sweep can send it to another process.
        options: :class:`~redservo.simulation.SimulationOptions` fields replaced for
            this run (e.g. ``qdot_max``, the controller's velocity saturation).
        scenario: Another shipped scenario for this run (the experiment's base and fast
            overrides do not apply to it), or None for the experiment's.
    """

    label: str
    method: str
    law_options: Mapping[str, Any] = field(default_factory=dict)
    overrides: tuple[str, ...] = ()
    setup: Callable[[Experiment], None] | None = None
    options: Mapping[str, Any] = field(default_factory=dict)
    scenario: str | None = None


@dataclass
class Runs:
    """The results of an experiment's runs, by label, and the experiments they ran on.

    Attributes:
        results: ``{label: SimulationResult}`` in run order.
        experiments: ``{label: Experiment}`` each run was made on.
        perturbation: The perturbed set-up, or None for the nominal one.
    """

    results: dict[str, SimulationResult]
    experiments: dict[str, Experiment]
    perturbation: Perturbation | None = None

    def __getitem__(self, label: str) -> SimulationResult:
        return self.results[label]

    @property
    def base(self) -> Experiment:
        """The experiment of the first run (built from the unmodified scenario)."""
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
        checks: The paper claims and implementation checks, in report order.
        fast: Scenario overrides for the quick version (tests).
        notes: How the scenario was chosen, shown in the report.
        base_overrides: Overrides applied to the shipped scenario for every run (an
            experiment that varies a shipped scenario).
        extra: ``f(runs) -> markdown`` appended to the report section (e.g. a table).
        variant_of: Id of the experiment whose statements this one checks again on
            another set-up (its paper claims are counted once in the headline), or "".
        fragility: What breaks its non-robust claims, one factor at a time, and whether the
            paper's own set-up would be broken too (markdown; printed with a robustness
            sweep; its numbers come from the sweep it names).
    """

    id: str
    title: str
    paper: str
    scenario: str
    runs: tuple[RunSpec, ...]
    figures: Callable[[Runs, Path], list[Path]]
    checks: tuple[Check, ...] = ()
    fast: tuple[str, ...] = ()
    notes: str = ""
    base_overrides: tuple[str, ...] = ()
    extra: Callable[[Runs], str] | None = None
    variant_of: str = ""
    fragility: str = ""

    def claims(self, runs: Runs) -> list[Claim]:
        """Evaluate every check on ``runs`` (report order)."""
        return evaluate(self.checks, runs)

    def check(self, name: str) -> Check:
        """The check called ``name`` (KeyError if none)."""
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(f"{self.id} has no check {name!r}; known: {[c.name for c in self.checks]}")


def nominal_scenario(spec: ExperimentSpec, *, fast: bool = False) -> Scenario:
    """The scenario every run of ``spec`` starts from (base overrides, then the fast ones)."""
    base = load_scenario(spec.scenario)
    if spec.base_overrides:
        base = apply_overrides(base, list(spec.base_overrides))
    if fast and spec.fast:
        base = apply_overrides(base, list(spec.fast))
    return base


def run_experiment(
    spec: ExperimentSpec,
    *,
    fast: bool = False,
    progress: Callable[[str], None] | None = None,
    perturbation: Perturbation | None = None,
    sensor: Callable[[Experiment], Sensor] | None = None,
) -> Runs:
    """Run every run of ``spec`` (the quick version with ``fast=True``).

    Args:
        spec: The experiment.
        fast: Apply ``spec.fast``.
        progress: Called with one line per run.
        perturbation: Run on this perturbed set-up instead of the nominal one.
        sensor: ``f(experiment) -> sensor`` measuring the features of every run, those on
            another scenario included (e.g. the image sensor of ``reproduce --sensor
            image``); None keeps each scenario's sensor (or the perturbation's).

    Raises:
        ScenarioError: the (perturbed) scenario is invalid, e.g. the target leaves the
            image at the start.
        ConfigurationError: a perturbation on an experiment with a run on another scenario
            (its start and target are not those the perturbation was drawn for).
    """
    base = nominal_scenario(spec, fast=fast)
    bound = perturbation.bind(base) if perturbation is not None else None
    built: dict[tuple[str | None, tuple[str, ...]], Experiment] = {}
    results: dict[str, SimulationResult] = {}
    experiments: dict[str, Experiment] = {}
    for run in spec.runs:
        key = (run.scenario, run.overrides)
        if bound is not None and run.scenario is not None:
            raise ConfigurationError(
                f"{spec.id}: run {run.label!r} is on scenario {run.scenario!r}, which a "
                "perturbed set-up drawn for the experiment's own scenario cannot move; use "
                "sensor= to change only the measurement",
                argument="perturbation",
            )
        if key not in built:
            sc = base if run.scenario is None else load_scenario(run.scenario)
            sc = apply_overrides(sc, list(run.overrides)) if run.overrides else sc
            if bound is not None:
                sc = bound.apply(sc)
            exp = build(sc)
            exp.limits = exp.limits.without_rates()  # the papers' robots: position limits only
            built[key] = exp
        exp = copy.copy(built[key])
        if bound is not None:
            exp.sensor = bound.sensor(exp)
        if sensor is not None:
            exp.sensor = sensor(exp)
        if run.setup is not None:
            run.setup(exp)
        if progress is not None:
            progress(f"{spec.id}: {run.label}")
        options = {**PAPER_EXACT, **run.law_options}
        results[run.label] = exp.run(method=run.method, law_options=options, **run.options)
        experiments[run.label] = exp
    return Runs(results, experiments, perturbation)
