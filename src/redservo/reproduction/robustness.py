"""Robustness of every claim: re-run each experiment on perturbed set-ups (``--robustness N``).

For each experiment, each **factor** (:data:`~redservo.reproduction.perturbation.FACTORS`:
target shift, target turn, start, period, depth error, pixel noise, blur, focal length, and
all of them together) and each set-up ``i < N`` a :class:`~redservo.reproduction.
perturbation.Perturbation` is drawn (deterministically from the seed) that moves that factor
alone, every run of the experiment is made on it and every check is evaluated. Per check and
factor the sweep reports how many set-ups it holds in, with a 95 % Wilson interval
(docs/formulas.md §12.8). The category is decided on the interval of the all-factors sweep,
never on its point estimate:

* **robust**: it holds on the nominal set-up and the interval's lower bound is at least
  ``ROBUST_LEVEL`` (70 %): at N = 20, 18 set-ups or more;
* **fragile**: it holds on the nominal set-up and the interval's *upper* bound is below
  ``ROBUST_LEVEL``: it clearly fails too often (at N = 20, 9 set-ups or fewer);
* **inconclusive**: it holds on the nominal set-up and the interval contains
  ``ROBUST_LEVEL``: more set-ups are needed to decide;
* **not reproduced**: it does not hold on the nominal set-up (the fractions are still given).

A single factor **breaks** a claim when the upper bound of its interval is below
``ROBUST_LEVEL``; the report names those factors, or the weakest one when none does.

A set-up whose scenario stays invalid after ``MAX_ATTEMPTS`` redraws, or whose simulation
raises, counts as a set-up where no check of the experiment holds (its error is kept).

The set-ups run in a process pool (``workers`` processes; each task is one experiment on one
set-up), so the sweep's time is about the total simulation time divided by the number of
cores. Results do not depend on the number of workers or on the completion order.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any

from redservo.errors import RedservoError, ScenarioError
from redservo.reproduction.base import ExperimentSpec, run_experiment
from redservo.reproduction.perturbation import (
    FACTORS,
    IMAGE_FACTORS,
    PERIODS,
    draw_perturbation,
    image_sensor_available,
)
from redservo.reproduction.registry import experiments
from redservo.reproduction.robustness_tally import (
    CATEGORIES,
    ROBUST_LEVEL,
    CheckRobustness,
    Robustness,
    SetupResult,
    aggregate,
    categorize,
)
from redservo.reproduction.unfiltered import FACTOR as UNFILTERED
from redservo.reproduction.unfiltered import draw_unfiltered

__all__ = [
    "CATEGORIES",
    "MAX_ATTEMPTS",
    "ROBUST_LEVEL",
    "CheckRobustness",
    "Robustness",
    "SetupResult",
    "categorize",
    "factors_for",
    "run_robustness",
    "run_setup",
]

MAX_ATTEMPTS = 20
"""Redraws of a set-up whose scenario is invalid before it counts as failed."""


def factors_for(fast: bool, pixel_noise: bool) -> tuple[str, ...]:
    """The factors a sweep can perturb: no period with the quick experiments (each keeps its
    quick period), no image factor without the image sensor."""
    return tuple(
        f
        for f in FACTORS
        if not (fast and f == "period") and (pixel_noise or f not in IMAGE_FACTORS)
    )


def run_setup(
    spec_id: str,
    index: int,
    seed: int,
    fast: bool,
    pixel_noise: bool,
    periods: bool,
    factor: str = "all",
) -> SetupResult:
    """Run experiment ``spec_id`` on set-up ``index`` of ``factor``; evaluate its checks."""
    spec = experiments()[spec_id]
    t0 = time.perf_counter()
    last = ""
    for attempt in range(MAX_ATTEMPTS):
        p = (
            draw_unfiltered(spec_id, index, seed=seed, attempt=attempt)
            if factor == UNFILTERED
            else draw_perturbation(
                spec_id,
                index,
                seed=seed,
                attempt=attempt,
                periods=PERIODS if periods else None,
                pixel_noise=pixel_noise,
                factor=factor,
            )
        )
        try:
            runs = run_experiment(spec, fast=fast, perturbation=p)
        except ScenarioError as exc:  # the target left the image at the start, ...: redraw
            last = str(exc)
            continue
        except RedservoError as exc:
            dt = time.perf_counter() - t0
            return SetupResult(spec_id, index, p.to_dict(), {}, dt, f"{exc}", factor)
        verdicts = {c.name: bool(c.reproduced) for c in spec.claims(runs)}
        return SetupResult(
            spec_id, index, p.to_dict(), verdicts, time.perf_counter() - t0, "", factor
        )
    dt = time.perf_counter() - t0
    return SetupResult(spec_id, index, None, {}, dt, f"no valid set-up: {last}", factor)


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
    factors: Sequence[str] | None = None,
    unfiltered: int = 0,
) -> Robustness:
    """Run every experiment of ``specs`` on ``n`` perturbed set-ups per factor (module docstring)
    and on ``unfiltered`` set-ups drawn without the phenomenon filter
    (:mod:`redservo.reproduction.unfiltered`; the factor ``"unfiltered"`` of the tallies).

    Args:
        specs: The experiments (those without checks are skipped).
        n: Set-ups per experiment and factor (>= 1; 0 with ``unfiltered`` > 0: those only).
        seed: Seed of the draws.
        fast: Use the quick experiments; the period is then not perturbed (each keeps
            its quick period).
        workers: Processes (default: the number of cores); 1 runs in this process.
        pixel_noise: Measure the features in a rendered image (the image factors); default:
            when OpenCV is installed.
        nominal: ``{(experiment id, check name): verdict}`` on the nominal set-up.
        progress: Called with one line per finished set-up.
        factors: The factors to sweep (default: every one available, :func:`factors_for`).
        unfiltered: Unfiltered set-ups per experiment (>= 0).

    Raises:
        ValueError: ``n < 0``, ``unfiltered < 0``, both 0, ``workers < 1`` or an unknown or
            unavailable factor.
    """
    if n < 0 or unfiltered < 0 or n + unfiltered < 1:
        raise ValueError(
            f"n and unfiltered must be >= 0 set-ups, one of them >= 1, got {n} and {unfiltered}"
        )
    nworkers = (os.cpu_count() or 1) if workers is None else int(workers)
    if nworkers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    noise = image_sensor_available() if pixel_noise is None else bool(pixel_noise)
    chosen = _chosen(factors, fast, noise) if n else ()
    todo = [spec for spec in specs if spec.checks]
    count = dict.fromkeys(chosen, n)
    if unfiltered:
        chosen, count[UNFILTERED] = (*chosen, UNFILTERED), unfiltered
    tasks = [
        (spec.id, i, seed, fast, noise, not fast, f)
        for f in chosen
        for i in range(count[f])
        for spec in todo
    ]
    t0 = time.perf_counter()
    results: list[SetupResult] = []

    def report(r: SetupResult) -> None:
        results.append(r)
        if progress is not None:
            status = f" — {r.error}" if r.error else ""
            elapsed = time.perf_counter() - t0
            left = elapsed / len(results) * (len(tasks) - len(results))
            progress(
                f"robustness: {len(results)}/{len(tasks)} set-ups done "
                f"({r.experiment}, {r.factor} #{r.index}, {r.seconds:.1f} s; "
                f"{elapsed:.0f} s elapsed, ~{left:.0f} s left){status}"
            )

    _execute(tasks, nworkers, report)
    checks = aggregate(todo, results, nominal or {}, chosen)
    order = [s.id for s in todo]
    return Robustness(
        n,
        seed,
        fast,
        noise,
        nworkers,
        time.perf_counter() - t0,
        checks,
        sorted(results, key=lambda r: (chosen.index(r.factor), order.index(r.experiment), r.index)),
        chosen,
        unfiltered,
    )


def _chosen(factors: Sequence[str] | None, fast: bool, noise: bool) -> tuple[str, ...]:
    """The factors to sweep (default: every available one); ValueError on another."""
    available = factors_for(fast, noise)
    chosen = available if factors is None else tuple(factors)
    bad = [f for f in chosen if f not in available]
    if bad or not chosen:
        raise ValueError(
            f"factors {bad or list(chosen)} not available here; available: {', '.join(available)}"
        )
    return chosen


def _execute(
    tasks: Sequence[tuple[Any, ...]], nworkers: int, report: Callable[[SetupResult], None]
) -> None:
    """Run every task (the arguments of :func:`_safe`), in ``nworkers`` processes when > 1."""
    if nworkers == 1 or len(tasks) == 1:
        for task in tasks:
            report(_safe(*task))
        return
    with ProcessPoolExecutor(max_workers=min(nworkers, len(tasks))) as pool:
        pending: set[Future[SetupResult]] = {pool.submit(_safe, *t) for t in tasks}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                report(fut.result())


def _safe(
    spec_id: str,
    index: int,
    seed: int,
    fast: bool,
    pixel_noise: bool,
    periods: bool,
    factor: str = "all",
) -> SetupResult:
    """:func:`run_setup`, with any unexpected exception recorded instead of raised."""
    try:
        return run_setup(spec_id, index, seed, fast, pixel_noise, periods, factor)
    except Exception as exc:  # a bug in one set-up must not lose the sweep
        tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return SetupResult(spec_id, index, None, {}, 0.0, f"internal error: {tb}", factor)
