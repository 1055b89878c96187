"""Monte Carlo comparison campaigns: every method on the same random variations of a scenario.

A *campaign definition* (TOML; shipped in ``redservo/scenarios/campaigns/`` and loadable by
name, or any path) names a base scenario and says how to vary it. :func:`run_campaign` draws
``N`` variations from a seed, runs every method on each of them (the same variations for all
methods), appends one row per (sample, method) to ``samples.csv`` as soon as it is finished,
and summarizes each method. This is the benchmark docs/formulas.md §12.6 recommends: random starts
near the limits; success = task converged with no limit crossed.

Definition format (every table is optional except ``scenario``)::

    name = "cm01-gaze"
    description = "one line"
    scenario = "cm01-gaze"          # shipped scenario name, or a .toml path relative to this file
    samples = 200                   # default N (run_campaign(samples=...) overrides)
    methods = ["classical", "gpm"]  # default methods (default: every name in redservo.METHODS)
    max_attempts = 100              # draws per sample before giving up (see "Invalid starts")

    [overrides]                     # deep-merged into the base scenario (e.g. an iteration cap)
    simulation = { max_iterations = 400 }

    [method_options.gpm]            # law options of one method; a method without an entry
    alpha = 2.0                     # gets the scenario's control.options if it is the
                                    # scenario's own method, and no options otherwise

    [start]                         # start configuration near the limits (see below)
    p_band = 0.5                    # probability that a joint starts in the outer band
    band_beyond = 0.5               # band reaches (1 + band_beyond) rho into the range
    min_margin = 0.01               # distance to the real limit, fraction of the range
    min_in_band = 1                 # at least this many joints start in the band
    joints = ["x", "z", "B"]        # joints that may start in the band (default: all)

    [target]                        # random placement relative to the start camera
    translation = [0.1, 0.1, [-0.1, 0.3]]  # per camera axis: ±h or [lo, hi] (m)
    rotation_deg = [10, 10, 30]            # per target axis: ±h or [lo, hi] (deg)
    image_margin_px = 10                   # the start image must be this far inside the border
    motion_frame = "camera"                # "camera" or "world" (see below)

    [errors]                        # noise and modelling errors, each optional
    noise_std = [0.0, 0.002]        # feature noise std (feature units): number or [lo, hi]
    depth_scale = [0.7, 1.3]        # controller depth Ẑ = depth_scale · Z: number or [lo, hi]
    hand_eye_translation = 0.01     # ± per axis (m) of the hand-eye error
    hand_eye_rotation_deg = 1.0     # ± per rotation-vector component (deg)

Start configurations (``[start]``). With ``Δq̄`` the range of a joint and ``rho`` the base
scenario's band width (the activation threshold ``q̃`` lies at margin ``rho``, CM01 eq. 3),
the *outer band* is the set of positions whose margin (distance to the nearer real limit over
``Δq̄``) lies in ``[min_margin, (1 + band_beyond) rho]``: the whole activation band plus a
strip ``band_beyond · rho`` wide just inside the threshold. Each eligible joint independently
starts in the outer band with probability ``p_band`` (side chosen with probability 1/2, margin
uniform in the interval); if fewer than ``min_in_band`` did, further eligible joints are chosen
uniformly until there are that many. Every other joint is uniform in the *inner range*
``[q̄_min + (1 + band_beyond) rho Δq̄, q̄_max - (1 + band_beyond) rho Δq̄]``. So every start is
legal by at least ``min_margin · Δq̄`` on every joint. :func:`sample_start` is this sampler.

Target placement (``[target]``). The base scenario is run at its own start to get every
object's pose in the start camera frame, ``cMo``. A sample keeps those relative poses and
applies one rigid perturbation to the whole scene: a rotation by the rotation vector ``r``
(components uniform in the ``rotation_deg`` ranges, converted to rad) about the origin and axes
of the *reference object* (the object of the first feature), then a translation ``t`` (uniform
in the ``translation`` ranges) expressed in the start camera frame::

    cMo_i' = T(t) · cMref · R(r) · cMref⁻¹ · cMo_i

The sample's scenario gives each object as ``pose_in_camera = cMo_i'`` and the robot as
``q0 = sampled q``; the desired pose (relative to the reference object) is unchanged. Object
motions (``constant_velocity``, ``waypoints``) are given in the world frame; with
``motion_frame = "camera"`` (default) their vectors are rotated by ``bRc' · bRc⁻¹`` (new and
nominal start camera orientations) so that the motion *relative to the start camera* is the
nominal one, which keeps a tracked target in view whatever the start; ``"world"`` keeps them.

Invalid starts. A drawn sample is *invalid* when the task cannot be evaluated at its start
(target behind the camera, degenerate features) or when an object is not inside the image by
``image_margin_px`` (the larger of ``[target].image_margin_px`` and the scenario's
``simulation.image_margin_px``) or is occluded. The check is the simulator's own: one
iteration of ``classical`` must not end in ``target_lost`` or ``occluded``. An invalid draw is
re-drawn deterministically: attempt ``a`` of sample ``i`` uses the generator seeded by
``SeedSequence(seed, spawn_key=(i, a))``, ``a = 0, 1, ...``; the number of rejected draws is
stored in the ``attempts`` column. After ``max_attempts`` rejections a
:class:`~redservo.errors.ScenarioError` says the variation spec is too wide.

Determinism and resumption. A sample depends only on ``(definition, seed, index)``, so the
rows do not depend on the number of workers or on the order runs finish, nor on the engine
(local processes, or a Dask cluster with ``scheduler=``) or on whether a run took the compiled
loop, which gives the rows of the object path (docs/scaling.md). With an output
directory, every finished row is appended to ``samples.csv`` (fsynced at once) and the
definition's fingerprint (SHA-256 of the canonical JSON of the definition, the base scenario
after overrides, the seed and :data:`FORMAT_VERSION`; not ``methods``, ``samples`` or
``description``) is stored in ``definition.json``. A rerun in the same directory reuses every
stored row and computes only the missing (sample, method) pairs, so adding samples or methods
extends a campaign; a different fingerprint is refused with a
:class:`~redservo.errors.ConfigurationError`. A run that raised an exception is stored with
outcome ``error`` (and the message in ``error``), counted as a failure, and recomputed on the
next rerun. Completeness is checked, not assumed: a (sample, method) still without a row at
the end (lost workers) raises :class:`CampaignIncompleteError`, which names them; the report
then states the N each method actually completed (docs/campaigns.md, "Completeness"). The
storage is locked, written in atomic batches, cleaned of torn and duplicated
rows on resume, repairable, and mirrored to ``samples.parquet``: docs/campaigns.md, "Storage"
(:mod:`redservo.campaign.storage`). This process keeps no row in memory: rows are read back
from the file when asked (``CampaignResult.rows``), the statistics keep numpy columns
(:mod:`redservo.campaign.table`), so memory stays flat in N (docs/scaling.md, "Memory").

Statistics (per method, over the first ``samples`` samples). Success = outcome ``converged``
(the simulator stops a run at the first limit crossing or lost target, so a converged run
never hit a limit nor lost the target). The success rate has a 95 % Wilson score interval
(:func:`wilson_interval`). Iterations to converge: median and 90th percentile over successes.
Peak joint speed (largest ``|q̇_i|`` over joints and time, rad/s or m/s: CM01's Afma6 mixes
both), peak camera translation (m/s) and rotation (rad/s) speed: median and 95th percentile
over all runs (a failed run counts with the peak it reached before it stopped). Discontinuity
(max ``‖Δq̇‖`` between steps) and minimum margin (fraction of the range): medians over all
runs. Percentiles use numpy's default (linear interpolation).

Decisions (for docs/decisions.md):
    * The outer band is measured from the real limit in units of the range and extends
      ``band_beyond · rho`` past the threshold, so the set-up is robot-independent and always
      includes starts just outside the band, where a law must *not* yet react.
    * The scene is perturbed rigidly relative to the start camera (not in the world): a random
      start configuration then never puts the target behind the camera by construction, and
      the required camera displacement has the same distribution for every start.
    * Peaks over all runs (not only successes), so a method is not rewarded for failing early.
    * ``success`` needs no separate "target lost" or "limit" check: those outcomes end the run.
"""

from __future__ import annotations

import math
import os
import sys
import types
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from redservo.campaign.client import CampaignResult, run
from redservo.campaign.complete import CampaignIncompleteError
from redservo.campaign.definition import (
    FORMAT_VERSION,
    CampaignDefinition,
    ErrorSpec,
    StartSpec,
    TargetSpec,
    load_campaign,
    parse_campaign,
    shipped_campaigns,
)
from redservo.campaign.engine import Engine
from redservo.campaign.sampling import Sample, draw_sample, sample_start
from redservo.campaign.sampling import _start_problem as _start_problem
from redservo.campaign.stats import MethodStats, method_stats, stats_table, wilson_interval
from redservo.campaign.storage import _Store
from redservo.errors import ConfigurationError, UnknownNameError
from redservo.schema.campaign import MAX_SAMPLES

__all__ = [
    "FORMAT_VERSION",
    "CampaignDefinition",
    "CampaignIncompleteError",
    "CampaignResult",
    "ErrorSpec",
    "MethodStats",
    "Sample",
    "StartSpec",
    "TargetSpec",
    "campaign_call",
    "draw_sample",
    "load_campaign",
    "method_stats",
    "parse_campaign",
    "run_campaign",
    "sample_start",
    "shipped_campaigns",
    "stats_table",
    "wilson_interval",
]


def run_campaign(
    campaign: str | Path | CampaignDefinition,
    *,
    methods: Sequence[str] | None = None,
    samples: int | None = None,
    seed: int = 0,
    workers: int | None = None,
    out: str | Path | None = None,
    progress: bool = True,
    wait: bool = False,
    repair: bool = False,
    scheduler: str | None = None,
    fast: bool = True,
    worker_timeout: float | None = None,
) -> CampaignResult:
    """Run a Monte Carlo campaign: every method on the same ``samples`` random variations.

    Args:
        campaign: A shipped campaign name, a definition file, or a :class:`CampaignDefinition`.
        methods: Methods to compare (default: the definition's list).
        samples: Number of samples N (default: the definition's).
        seed: Non-negative seed; sample ``i`` depends only on ``(definition, seed, i)``.
        workers: Processes (default: all cores); 1 runs in this process.
        out: Output directory for ``samples.csv`` (resumable), ``definition.json``,
            ``campaign.json``, ``campaign.md`` and figures; None writes nothing.
        progress: Show a progress bar on stderr (tqdm, if installed and stderr is a terminal).
        wait: When another process is writing to ``out``, wait for it instead of raising.
        repair: Rebuild a damaged ``definition.json`` or ``samples.csv`` header, keeping the
            rows that are intact and belong to this campaign (docs/campaigns.md, "Storage").
        scheduler: Address of a Dask scheduler (``tcp://HOST:PORT``, extra ``redservo[dask]``)
            to run the samples on that cluster instead of local processes (``workers`` is
            then unused); this process still stores every row (docs/scaling.md).
        fast: Run each covered (sample, method) on the compiled closed loop
            (:mod:`redservo.campaign.fastloop`; identical rows, needs ``redservo[fast]``);
            the others, and every run with ``fast=False``, on the object path. One line on
            stderr names the methods that fell back and why.
        worker_timeout: With ``scheduler``: how long to wait while the scheduler has no
            worker before the campaign stops (s; default
            :data:`~redservo.campaign.engine.NO_WORKER_TIMEOUT_S`). Said on stderr.

    Returns:
        :class:`CampaignResult`.

    Raises:
        ScenarioError: bad definition, or no valid start for a sample.
        UnknownNameError: unknown method.
        ConfigurationError: bad ``samples``/``seed``/``workers``/``scheduler``; ``out``
            holds another campaign, is in use by another process (without ``wait``) or is
            damaged (without ``repair``); no Dask scheduler at ``scheduler``; bad
            ``worker_timeout``.
        CampaignIncompleteError: a (sample, method) has no row at the end (workers lost):
            it names them; the rows computed are stored and a rerun computes only the
            missing ones (docs/campaigns.md, "Completeness").
    """
    from redservo.redundancy import METHODS

    defn = campaign if isinstance(campaign, CampaignDefinition) else load_campaign(campaign)
    names = tuple(methods) if methods is not None else defn.methods
    for m in names:
        if m not in METHODS:
            from redservo.schema.base import unknown_name

            raise UnknownNameError(unknown_name("method", m, METHODS))  # with "did you mean"
    if not names or len(set(names)) != len(names):
        raise ConfigurationError(f"methods must be a non-empty list without repeats, got {names}")
    n = defn.samples if samples is None else int(samples)
    if not 1 <= n <= MAX_SAMPLES:
        raise ConfigurationError(f"samples must be in [1, {MAX_SAMPLES}], got {samples}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ConfigurationError(f"seed must be a non-negative integer, got {seed!r}")
    seed = int(seed)
    engine = _engine(workers, scheduler, fast, worker_timeout)
    out_dir = Path(out) if out is not None else None
    store = _Store(out_dir, defn, seed, wait=wait, repair=repair) if out_dir is not None else None
    try:
        return run(defn, names, n, seed, engine, out_dir, store, progress)
    finally:
        if store is not None:
            store.close()


def _engine(
    workers: int | None, scheduler: str | None, fast: bool, worker_timeout: float | None
) -> Engine:
    """The engine of :func:`run_campaign`'s arguments.

    Raises:
        ConfigurationError: bad ``workers``, ``scheduler`` or ``worker_timeout``.
    """
    n_workers = (os.cpu_count() or 1) if workers is None else int(workers)
    if not 1 <= n_workers <= 1024:
        raise ConfigurationError(f"workers must be in [1, 1024], got {workers}")
    if scheduler is not None and (not isinstance(scheduler, str) or "://" not in scheduler):
        raise ConfigurationError(
            f"scheduler must be a Dask scheduler address such as tcp://HOST:8786, got "
            f"{scheduler!r}",
            argument="scheduler",
        )
    timeout = worker_timeout
    if timeout is not None:
        ok = isinstance(timeout, int | float | np.floating) and not isinstance(timeout, bool)
        if not ok or not 0 < float(timeout) < math.inf:
            raise ConfigurationError(
                f"worker_timeout must be a positive number of seconds, got {timeout!r}",
                argument="worker_timeout",
            )
        timeout = float(timeout)
    return Engine(n_workers, scheduler, bool(fast), timeout)


def campaign_call(
    definition: str | Path,
    *,
    methods: Sequence[str] | None = None,
    samples: int | None = None,
    seed: int = 0,
    workers: int | None = 1,
    overrides: Any = None,
    out: str | Path | None = None,
    progress: bool = False,
) -> CampaignResult:
    """:func:`redservo.api.campaign` (documented there): :func:`run_campaign` with the base
    scenario's ``overrides`` applied, and the files it references copied into ``out/files/``
    so that ``redservo replay`` works on the directory once moved (:mod:`redservo.runs.files`)."""
    import copy
    from dataclasses import replace

    from redservo.experiment.overrides import as_assignments
    from redservo.runs.files import bundle_files
    from redservo.scenario import apply_overrides

    defn = load_campaign(definition)
    sets = as_assignments(overrides)
    if sets:
        defn = replace(defn, scenario=apply_overrides(defn.scenario, sets))
    result = run_campaign(
        defn,
        methods=methods,
        samples=samples,
        seed=seed,
        workers=workers,
        out=out,
        progress=progress,
    )
    if result.out is not None:
        bundle_files(Path(result.out), copy.deepcopy(defn.scenario.data))
    return result


class _CallableModule(types.ModuleType):
    """``redservo.campaign(...)`` is :func:`redservo.api.campaign` (the top-level API), while
    ``redservo.campaign`` stays this package: calling the package runs a campaign."""

    def __call__(self, *args: Any, **kwargs: Any) -> CampaignResult:
        return campaign_call(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
