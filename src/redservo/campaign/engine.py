"""Where a campaign's runs execute: this process, a local process pool, or a Dask cluster.

The unit of work is a :class:`Job`: a few samples and, for each, the methods still to run.
A job draws its samples itself (a sample depends only on ``(definition, seed, index)``),
builds each sample's experiment once, runs its methods (on the compiled loop of
:mod:`redservo.campaign.fastloop` when it applies) and returns the rows. Only the process
that called :func:`redservo.campaign.run_campaign` stores rows, so the storage guarantees
of :mod:`redservo.campaign.storage` hold whatever the engine (docs/campaigns.md, "Storage").

Engines (docs/scaling.md):

* ``workers == 1``: the jobs run in this process;
* a local :class:`~concurrent.futures.ProcessPoolExecutor` (the default), whose workers exit
  when this process dies (:func:`redservo.campaign.lock.worker_init`);
* a Dask cluster (``scheduler="tcp://HOST:PORT"``, optional extra ``redservo[dask]``): the
  jobs are submitted to an existing scheduler through a :class:`distributed.Client`, a
  bounded number at a time, and their rows stored as they complete.

The rows do not depend on the engine, the number of workers or the order jobs finish.
"""

from __future__ import annotations

import math
import os
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import replace
from typing import Any, NamedTuple

from redservo.campaign.definition import CampaignDefinition
from redservo.campaign.lock import worker_init
from redservo.errors import ConfigurationError

__all__ = [
    "FAST_PATH",
    "Engine",
    "Job",
    "JobResult",
    "connect",
    "execute",
    "fallback_lines",
    "make_jobs",
    "merge",
    "run_job",
]

FAST_PATH = "compiled loop"
"""The ``path`` note of a run on the compiled loop (any other note is a fallback reason)."""
CONNECT_TIMEOUT_S = 20.0
"""How long :func:`connect` tries to reach the scheduler (s)."""
_DEFS: dict[str, CampaignDefinition] = {}
"""Definitions unpickled in this worker, by fingerprint (their ``nominal`` computed once)."""


class Engine(NamedTuple):
    """Where and how the runs execute (module docstring)."""

    workers: int
    """Local processes (1: this process); unused with a scheduler."""
    scheduler: str | None = None
    """Dask scheduler address, or None for the local engine."""
    fast: bool = True
    """Use the compiled loop where it applies."""

    def per_job(self, n_samples: int) -> int:
        """Samples per job: one per job with up to 8 local workers (one more per 8 workers,
        so that the client's writes keep up); on Dask up to 16 (about 64 jobs in all), so
        that the scheduler's cost per task (~1 ms) stays small."""
        if self.scheduler is None:
            return 1 + self.workers // 8
        return max(1, min(16, math.ceil(n_samples / 64)))


class Job(NamedTuple):
    """Samples to run, with the methods still missing for each (picklable)."""

    definition: CampaignDefinition
    key: str
    """The definition's fingerprint (the workers' cache key)."""
    seed: int
    samples: tuple[tuple[int, tuple[str, ...]], ...]
    fast: bool
    """Use the compiled loop where it applies."""


class JobResult(NamedTuple):
    """The rows of a job, and how many runs took each path."""

    rows: list[dict[str, Any]]
    paths: dict[tuple[str, str], int]
    """``(method, FAST_PATH or the reason it fell back)`` -> number of runs."""


def make_jobs(
    defn: CampaignDefinition,
    seed: int,
    todo: Sequence[tuple[int, str]],
    *,
    fast: bool,
    per_job: int = 1,
) -> Iterator[Job]:
    """Group the missing ``(sample, method)`` pairs by sample, ``per_job`` samples a job."""
    by_sample: dict[int, list[str]] = {}
    for i, m in todo:
        by_sample.setdefault(i, []).append(m)
    portable = replace(defn)  # without the cached (unpicklable) nominal evaluation
    key = defn.fingerprint(seed)
    items = [(i, tuple(ms)) for i, ms in by_sample.items()]
    for k in range(0, len(items), per_job):
        yield Job(portable, key, seed, tuple(items[k : k + per_job]), fast)


def _definition(job: Job) -> CampaignDefinition:
    defn = _DEFS.get(job.key)
    if defn is None:
        if len(_DEFS) > 8:
            _DEFS.clear()
        defn = _DEFS[job.key] = job.definition
    return defn


def run_job(job: Job) -> JobResult:
    """Run a job's samples and methods; a run that raises becomes an ``error`` row.

    The runs go through ``redservo.campaign._run_task`` (looked up at call time).

    Raises:
        ScenarioError: a sample has no valid start (the whole campaign stops, as before).
    """
    import redservo.campaign as campaign
    from redservo.campaign.sampling import draw_sample
    from redservo.campaign.storage import _sample_columns
    from redservo.experiment import build

    defn = _definition(job)
    joint_names = defn.nominal.joint_names
    rows: list[dict[str, Any]] = []
    paths: Counter[tuple[str, str]] = Counter()
    for i, methods in job.samples:
        s = draw_sample(defn, job.seed, i)
        params = _sample_columns(s, joint_names)
        try:
            exp = build(s.scenario)
        except Exception:  # each run builds again and records the error in its row
            exp = None
        for m in methods:
            opts = defn.method_options.get(m)
            task = campaign._Task(
                i,
                m,
                s.scenario.data,
                s.scenario.source,
                dict(opts) if opts is not None else None,
                params,
                exp,
                job.fast,
            )
            row = campaign._run_task(task)
            path = row.pop("_path", None)
            if path is not None:
                paths[(m, str(path))] += 1
            rows.append(row)
    return JobResult(rows, dict(paths))


OnResult = Callable[[JobResult], None]


def merge(results: Sequence[JobResult]) -> JobResult:
    """One result of several jobs that finished together (stored in one atomic write)."""
    rows = [row for r in results for row in r.rows]
    paths: Counter[tuple[str, str]] = Counter()
    for r in results:
        paths.update(r.paths)
    return JobResult(rows, dict(paths))


def _local(jobs: Iterable[Job], workers: int, on_result: OnResult) -> None:
    if workers == 1:
        for job in jobs:
            on_result(run_job(job))
        return
    with ProcessPoolExecutor(
        max_workers=workers, initializer=worker_init, initargs=(os.getpid(),)
    ) as pool:
        pending: set[Future[JobResult]] = set()
        try:
            for job in jobs:
                pending.add(pool.submit(run_job, job))
                # A bounded queue: rows are stored while later jobs are still queued.
                while len(pending) >= 2 * workers:
                    done, pending = wait(pending, return_when=FIRST_COMPLETED)
                    on_result(merge([fut.result() for fut in done]))
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                on_result(merge([fut.result() for fut in done]))
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def _distributed() -> Any:
    try:
        import distributed
    except ImportError:
        raise ConfigurationError(
            "--scheduler needs Dask's distributed: pip install 'redservo[dask]'",
            argument="scheduler",
        ) from None
    return distributed


def connect(scheduler: str, *, timeout: float | None = None) -> Any:
    """A :class:`distributed.Client` of the scheduler at ``scheduler`` (e.g. tcp://HOST:8786),
    tried for ``timeout`` seconds (default :data:`CONNECT_TIMEOUT_S`).

    Raises:
        ConfigurationError: not an address, ``distributed`` missing, or no scheduler there.
    """
    if not isinstance(scheduler, str) or "://" not in scheduler:
        raise ConfigurationError(
            f"scheduler must be a Dask scheduler address such as tcp://HOST:8786, "
            f"got {scheduler!r}",
            argument="scheduler",
        )
    distributed = _distributed()
    timeout = CONNECT_TIMEOUT_S if timeout is None else timeout
    try:
        return distributed.Client(scheduler, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise ConfigurationError(
            f"cannot reach the Dask scheduler at {scheduler} within {timeout:g} s "
            f"({type(exc).__name__}: {exc}); start one with `dask scheduler` and workers "
            f"with `dask worker {scheduler}` (docs/scaling.md)",
            argument="scheduler",
        ) from None


def _dask(jobs: Iterable[Job], scheduler: str, on_result: OnResult) -> None:
    distributed = _distributed()
    it = iter(jobs)
    with connect(scheduler) as client:
        threads = max(1, sum(client.nthreads().values()))
        # A bounded queue (two jobs per worker thread), refilled as jobs complete; the jobs
        # that completed together are stored together.
        first = [client.submit(run_job, job, pure=False) for job, _ in zip(it, range(2 * threads))]
        if not first:
            return
        queue = distributed.as_completed(first, loop=client.loop)
        for batch in queue.batches():
            results: list[JobResult] = [fut.result() for fut in batch]
            for fut in batch:
                fut.release()
            on_result(merge(results))
            for _ in batch:
                job = next(it, None)
                if job is not None:
                    queue.add(client.submit(run_job, job, pure=False))


def execute(jobs: Iterable[Job], engine: Engine, on_result: OnResult) -> None:
    """Run ``jobs`` on ``engine`` (module docstring), calling ``on_result`` in this process
    with each finished job."""
    if engine.scheduler is not None:
        _dask(jobs, engine.scheduler, on_result)
    else:
        _local(jobs, engine.workers, on_result)


def fallback_lines(paths: dict[tuple[str, str], int]) -> list[str]:
    """One line per reason some runs left the compiled loop: the methods and the count."""
    by_reason: dict[str, dict[str, int]] = {}
    for (method, path), count in paths.items():
        if path != FAST_PATH:
            by_reason.setdefault(path, {})
            by_reason[path][method] = by_reason[path].get(method, 0) + count
    return [
        f"{sum(ms.values())} run(s) of {', '.join(ms)} on the object path, not the compiled "
        f"loop: {reason}"
        for reason, ms in sorted(by_reason.items())
    ]
