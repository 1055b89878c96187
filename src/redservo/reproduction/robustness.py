"""Robustness of every claim: re-run each experiment on N perturbed set-ups (``--robustness N``).

For each experiment and each set-up ``i < N`` a :class:`~redservo.reproduction.perturbation.
Perturbation` is drawn (deterministically from the seed), every run of the experiment is
made on it and every check is evaluated. Per check the sweep reports how many set-ups it
holds in, with a 95 % Wilson interval (docs/formulas.md §12.8), and sorts it:

* **robust**: it holds on the nominal set-up and in at least ``ROBUST_FRACTION`` (80 %) of
  the perturbed ones;
* **fragile**: it holds on the nominal set-up, in fewer than 80 % of the perturbed ones;
* **not reproduced**: it does not hold on the nominal set-up (the fraction is still given).

A set-up whose scenario stays invalid after ``MAX_ATTEMPTS`` redraws, or whose simulation
raises, counts as a set-up where no check of the experiment holds (its error is kept).

The set-ups run in a process pool (``workers`` processes; each task is one experiment on
one set-up), so the sweep's time is about the total simulation time divided by the number
of cores. Results do not depend on the number of workers or on the completion order.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any, Literal

from redservo.campaign.stats import wilson_interval
from redservo.errors import RedservoError, ScenarioError
from redservo.reproduction.base import ExperimentSpec, run_experiment
from redservo.reproduction.checks import Kind
from redservo.reproduction.perturbation import PERIODS, draw_perturbation, image_sensor_available
from redservo.reproduction.registry import experiments

__all__ = [
    "MAX_ATTEMPTS",
    "ROBUST_FRACTION",
    "CheckRobustness",
    "Robustness",
    "SetupResult",
    "run_robustness",
    "run_setup",
]

ROBUST_FRACTION = 0.8
"""A claim holding in at least this fraction of the perturbed set-ups is robust."""
MAX_ATTEMPTS = 20
"""Redraws of a set-up whose scenario is invalid before it counts as failed."""

Category = Literal["robust", "fragile", "not reproduced"]


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
    """

    experiment: str
    index: int
    perturbation: dict[str, Any] | None
    verdicts: dict[str, bool]
    seconds: float
    error: str = ""


def run_setup(
    spec_id: str, index: int, seed: int, fast: bool, pixel_noise: bool, periods: bool
) -> SetupResult:
    """Run experiment ``spec_id`` on set-up ``index`` and evaluate its checks (pool task)."""
    spec = experiments()[spec_id]
    t0 = time.perf_counter()
    last = ""
    for attempt in range(MAX_ATTEMPTS):
        p = draw_perturbation(
            spec_id,
            index,
            seed=seed,
            attempt=attempt,
            periods=PERIODS if periods else None,
            pixel_noise=pixel_noise,
        )
        try:
            runs = run_experiment(spec, fast=fast, perturbation=p)
        except ScenarioError as exc:  # the target left the image at the start, ...: redraw
            last = str(exc)
            continue
        except RedservoError as exc:
            return SetupResult(spec_id, index, p.to_dict(), {}, time.perf_counter() - t0, f"{exc}")
        verdicts = {c.name: bool(c.reproduced) for c in spec.claims(runs)}
        return SetupResult(spec_id, index, p.to_dict(), verdicts, time.perf_counter() - t0)
    return SetupResult(
        spec_id, index, None, {}, time.perf_counter() - t0, f"no valid set-up: {last}"
    )


@dataclass
class CheckRobustness:
    """How one check fares over the perturbed set-ups.

    Attributes:
        experiment: Experiment id.
        name: Check name.
        text: The statement.
        kind: Paper claim or implementation check.
        nominal: The verdict on the nominal set-up (None if the nominal run was not made).
        holds: Number of set-ups it holds in.
        n: Number of set-ups.
        interval: 95 % Wilson interval of the fraction.
        by_period: ``{period in ms: [holds, n]}``.
        failing: Indices of the set-ups where it does not hold.
    """

    experiment: str
    name: str
    text: str
    kind: Kind
    nominal: bool | None
    holds: int
    n: int
    interval: tuple[float, float]
    by_period: dict[str, list[int]] = field(default_factory=dict)
    failing: list[int] = field(default_factory=list)

    @property
    def fraction(self) -> float:
        return self.holds / self.n if self.n else 0.0

    @property
    def category(self) -> Category:
        if self.nominal is False:
            return "not reproduced"
        return "robust" if self.fraction >= ROBUST_FRACTION else "fragile"

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
            "by_period_ms": self.by_period,
            "failing_setups": self.failing,
        }


@dataclass
class Robustness:
    """The sweep's results: per check, and per set-up.

    Attributes:
        n: Set-ups per experiment.
        seed: Seed of the draws.
        fast: Whether the quick experiments were used (the period is then not perturbed).
        pixel_noise: Whether the image sensor measured the features.
        workers: Processes used.
        seconds: Wall time of the sweep.
        checks: One entry per check of every experiment, in report order.
        setups: Every set-up run.
    """

    n: int
    seed: int
    fast: bool
    pixel_noise: bool
    workers: int
    seconds: float
    checks: list[CheckRobustness]
    setups: list[SetupResult]

    def by_category(self, kind: Kind | None = None) -> dict[Category, list[CheckRobustness]]:
        """``{category: [checks]}`` (only ``kind`` when given), in report order."""
        out: dict[Category, list[CheckRobustness]] = {
            "robust": [],
            "fragile": [],
            "not reproduced": [],
        }
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
            "checks": [c.to_dict() for c in self.checks],
            "setups": [s.__dict__ for s in self.setups],
        }


def _aggregate(
    specs: Sequence[ExperimentSpec],
    setups: list[SetupResult],
    nominal: Mapping[tuple[str, str], bool],
) -> list[CheckRobustness]:
    out: list[CheckRobustness] = []
    for spec in specs:
        mine = sorted((s for s in setups if s.experiment == spec.id), key=lambda s: s.index)
        for check in spec.checks:
            ok = [s.verdicts.get(check.name, False) for s in mine]
            by_period: dict[str, list[int]] = {}
            for s, v in zip(mine, ok, strict=True):
                per = s.perturbation.get("period") if s.perturbation else None
                key = "nominal" if per is None else f"{per * 1e3:.0f}"
                tally = by_period.setdefault(key, [0, 0])
                tally[0] += int(v)
                tally[1] += 1
            k = sum(ok)
            out.append(
                CheckRobustness(
                    spec.id,
                    check.name,
                    check.text,
                    check.kind,
                    nominal.get((spec.id, check.name)),
                    k,
                    len(ok),
                    wilson_interval(k, len(ok)),
                    by_period,
                    [s.index for s, v in zip(mine, ok, strict=True) if not v],
                )
            )
    return out


def run_robustness(
    specs: Sequence[ExperimentSpec],
    n: int,
    *,
    seed: int = 0,
    fast: bool = False,
    workers: int | None = None,
    pixel_noise: bool | None = None,
    nominal: Mapping[tuple[str, str], bool] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Robustness:
    """Run every experiment of ``specs`` on ``n`` perturbed set-ups (module docstring).

    Args:
        specs: The experiments (those without checks are skipped).
        n: Set-ups per experiment (>= 1).
        seed: Seed of the draws.
        fast: Use the quick experiments; the period is then not perturbed (each keeps
            its quick period).
        workers: Processes (default: the number of cores); 1 runs in this process.
        pixel_noise: Measure the features in a noisy image; default: when OpenCV is
            installed.
        nominal: ``{(experiment id, check name): verdict}`` on the nominal set-up.
        progress: Called with one line per finished set-up.

    Raises:
        ValueError: ``n < 1`` or ``workers < 1``.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1 set-up, got {n}")
    nworkers = (os.cpu_count() or 1) if workers is None else int(workers)
    if nworkers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    noise = image_sensor_available() if pixel_noise is None else bool(pixel_noise)
    todo = [spec for spec in specs if spec.checks]
    tasks = [(spec.id, i, seed, fast, noise, not fast) for i in range(n) for spec in todo]
    t0 = time.perf_counter()
    results: list[SetupResult] = []

    def report(r: SetupResult) -> None:
        results.append(r)
        if progress is not None:
            status = f" — {r.error}" if r.error else ""
            progress(
                f"robustness: {len(results)}/{len(tasks)} set-ups done "
                f"({r.experiment} #{r.index}, {r.seconds:.1f} s; "
                f"{time.perf_counter() - t0:.0f} s elapsed){status}"
            )

    if nworkers == 1 or len(tasks) == 1:
        for task in tasks:
            report(_safe(*task))
    else:
        with ProcessPoolExecutor(max_workers=min(nworkers, len(tasks))) as pool:
            pending: set[Future[SetupResult]] = {pool.submit(_safe, *t) for t in tasks}
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    report(fut.result())
    checks = _aggregate(todo, results, nominal or {})
    return Robustness(
        n,
        seed,
        fast,
        noise,
        nworkers,
        time.perf_counter() - t0,
        checks,
        sorted(results, key=lambda r: ([s.id for s in todo].index(r.experiment), r.index)),
    )


def _safe(
    spec_id: str, index: int, seed: int, fast: bool, pixel_noise: bool, periods: bool
) -> SetupResult:
    """:func:`run_setup`, with any unexpected exception recorded instead of raised."""
    try:
        return run_setup(spec_id, index, seed, fast, pixel_noise, periods)
    except Exception as exc:  # a bug in one set-up must not lose the sweep
        tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return SetupResult(spec_id, index, None, {}, 0.0, f"internal error: {tb}")
