"""Where a campaign's runs execute: this process, a local process pool, or a Dask cluster.

The unit of work is a :class:`~redservo.campaign.task.Job` (:mod:`redservo.campaign.task`):
a few samples and, for each, the methods still to run. Only the process that called
:func:`redservo.campaign.run_campaign` stores rows, so the storage guarantees of
:mod:`redservo.campaign.storage` hold whatever the engine (docs/campaigns.md, "Storage").

Engines (docs/scaling.md):

* ``workers == 1``: the jobs run in this process;
* a local :class:`~concurrent.futures.ProcessPoolExecutor` (the default), whose workers exit
  when this process dies (:func:`redservo.campaign.lock.worker_init`) and run one BLAS
  thread each (:func:`redservo.kernels.blas.pin_process`; every engine's jobs run inside
  :func:`redservo.kernels.blas.one_blas_thread`);
* a Dask cluster (``scheduler="tcp://HOST:PORT"``, optional extra ``redservo[dask]``): the
  jobs are submitted to an existing scheduler through a :class:`distributed.Client`, a
  bounded number at a time (two per worker thread), and their rows stored as they complete.

Every engine hands every job's rows to ``on_result`` or raises; the client checks it anyway
(:mod:`redservo.campaign.complete`). A job whose Dask workers died is run again: the
scheduler does it itself up to ``distributed.scheduler.allowed-failures`` times, then this
client submits it again up to :data:`MAX_RESUBMITS` times before it stops with
:class:`~redservo.campaign.complete.CampaignIncompleteError`. When the scheduler has no
worker, the client says so on stderr and waits up to :data:`NO_WORKER_TIMEOUT_S` for one,
then stops with the same error (the stored rows are kept; rerunning resumes). A local worker
process that dies (killed, out of memory) stops the campaign with that error too.

The rows do not depend on the engine, the number of workers or the order jobs finish.
"""

from __future__ import annotations

import itertools
import math
import os
import sys
import time
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, NamedTuple

from redservo.campaign.complete import CampaignIncompleteError
from redservo.campaign.lock import worker_init
from redservo.campaign.task import (
    FAST_PATH,
    Job,
    JobResult,
    fallback_lines,
    job_samples,
    make_jobs,
    merge,
    run_job,
)
from redservo.errors import ConfigurationError

__all__ = [
    "FAST_PATH",
    "MAX_RESUBMITS",
    "NO_WORKER_TIMEOUT_S",
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

CONNECT_TIMEOUT_S = 20.0
"""How long :func:`connect` tries to reach the scheduler (s)."""
NO_WORKER_TIMEOUT_S = 60.0
"""How long a Dask campaign waits while the scheduler has no worker before it stops (s)."""
MAX_RESUBMITS = 2
"""How many times a job that ended in ``KilledWorker`` is submitted again before the campaign
stops (each submission is itself retried by the scheduler on up to
``distributed.scheduler.allowed-failures`` workers)."""
_POLL_S = 1.0
"""How often the Dask client looks at the workers while no job completes (s)."""


class Engine(NamedTuple):
    """Where and how the runs execute (module docstring)."""

    workers: int
    """Local processes (1: this process); unused with a scheduler."""
    scheduler: str | None = None
    """Dask scheduler address, or None for the local engine."""
    fast: bool = True
    """Use the compiled loop where it applies."""
    worker_timeout: float | None = None
    """Dask: how long to wait while no worker is connected (s); None:
    :data:`NO_WORKER_TIMEOUT_S`."""

    def per_job(self, n_samples: int) -> int:
        """Samples per job: one per job with up to 8 local workers (one more per 8 workers,
        so that the client's writes keep up); on Dask up to 16 (about 64 jobs in all), so
        that the scheduler's cost per task (~1 ms) stays small."""
        if self.scheduler is None:
            return 1 + self.workers // 8
        return max(1, min(16, math.ceil(n_samples / 64)))


OnResult = Callable[[JobResult], None]


def _say(message: str) -> None:
    print(f"redservo campaign: {message}", file=sys.stderr, flush=True)


def _store_then_raise(futures: Iterable[Future[JobResult]], on_result: OnResult) -> None:
    """Store the rows of the jobs that succeeded, then raise the first failure (if any)."""
    results: list[JobResult] = []
    error: BaseException | None = None
    for fut in futures:
        exc = fut.exception()
        if exc is None:
            results.append(fut.result())
        elif error is None:
            error = exc
    if results:
        on_result(merge(results))
    if isinstance(error, BrokenProcessPool):
        raise CampaignIncompleteError(
            "a local worker process died (killed, or out of memory)"
        ) from error
    if error is not None:
        raise error


def _worker_start(parent: int) -> None:
    """Pool initializer: exit with ``parent`` (:func:`~redservo.campaign.lock.worker_init`),
    one BLAS thread for the worker's life (:func:`redservo.kernels.blas.pin_process`)."""
    from redservo.kernels.blas import pin_process

    worker_init(parent)
    pin_process()


def _local(jobs: Iterable[Job], workers: int, on_result: OnResult) -> None:
    if workers == 1:
        for job in jobs:
            on_result(run_job(job))
        return
    with ProcessPoolExecutor(
        max_workers=workers, initializer=_worker_start, initargs=(os.getpid(),)
    ) as pool:
        pending: set[Future[JobResult]] = set()
        try:
            for job in jobs:
                pending.add(pool.submit(run_job, job))
                # A bounded queue: rows are stored while later jobs are still queued.
                while len(pending) >= 2 * workers:
                    done, pending = wait(pending, return_when=FIRST_COMPLETED)
                    _store_then_raise(done, on_result)
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                _store_then_raise(done, on_result)
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


class _Workers:
    """The scheduler's worker threads as the client sees them, and the bounded wait while
    there are none."""

    def __init__(self, client: Any, address: str, timeout: float) -> None:
        self.client, self.address, self.timeout = client, address, timeout
        self.gone_since: float | None = None
        """When the client first saw no worker (monotonic s), or None while there are some."""

    def threads(self) -> int:
        """Worker threads now (0 while waiting for a worker).

        Raises:
            CampaignIncompleteError: no worker for longer than the timeout, or the client
                lost the scheduler (it has already tried to reconnect for its own
                ``distributed.comm.timeouts.connect``).
        """
        try:
            if self.client.status in ("closing", "closed"):
                raise OSError("the client closed its connection")
            threads = sum(self.client.nthreads().values())
        except (OSError, TimeoutError, RuntimeError) as exc:
            raise CampaignIncompleteError(
                f"lost the connection to the Dask scheduler at {self.address} ({exc})"
            ) from exc
        now = time.monotonic()
        if threads > 0:
            if self.gone_since is not None:
                _say("a Dask worker is connected again: the campaign goes on")
            self.gone_since = None
        elif self.gone_since is None:
            self.gone_since = now
            _say(
                f"no Dask worker is connected to {self.address}; waiting up to "
                f"{self.timeout:g} s for one (start workers with `dask worker {self.address}`;"
                " the rows so far are stored)"
            )
        elif now - self.gone_since > self.timeout:
            raise CampaignIncompleteError(
                f"no Dask worker is connected to {self.address} for {self.timeout:g} s"
            )
        return threads


def _completed(distributed: Any, pending: dict[Any, tuple[Job, int]]) -> list[Any]:
    """The pending futures that finished, failed or were cancelled, after waiting up to
    :data:`_POLL_S` for one (a future whose result was lost with its worker is pending)."""
    try:
        distributed.wait(list(pending), timeout=_POLL_S, return_when="FIRST_COMPLETED")
    except (TimeoutError, distributed.client.FuturesCancelledError):
        pass  # nothing yet, or cancelled futures: both sorted out by their status below
    return [f for f in pending if f.status in ("finished", "error", "cancelled")]


def _killed(exc: BaseException | None) -> str:
    """Why a job is lost: cancelled (``exc`` None), or the scheduler's ``KilledWorker``."""
    if exc is None:
        return "cancelled"
    tried = getattr(exc, "allowed_failures", None)
    if isinstance(tried, int):
        return f"KilledWorker: {tried + 1} workers died running it"
    return "KilledWorker"


def _dask(jobs: Iterable[Job], scheduler: str, on_result: OnResult, timeout: float) -> None:
    distributed = _distributed()
    it = iter(jobs)
    with connect(scheduler) as client, client.as_current():  # the client distributed.wait uses
        workers = _Workers(client, scheduler, timeout)
        pending: dict[Any, tuple[Job, int]] = {}  # future -> (job, resubmissions so far)

        def submit(job: Job, tries: int) -> None:
            pending[client.submit(run_job, job, pure=False)] = (job, tries)

        while True:
            threads = workers.threads()
            # A bounded queue (two jobs per worker thread), refilled as jobs complete.
            for job in itertools.islice(it, max(0, 2 * threads - len(pending))):
                submit(job, 0)
            if not pending:
                if threads > 0:
                    return  # nothing pending, and the refill found no job left
                time.sleep(_POLL_S)  # waiting for a worker (said on stderr)
                continue
            results: list[JobResult] = []
            error: BaseException | None = None
            for fut in _completed(distributed, pending):
                job, tries = pending.pop(fut)
                if fut.status == "finished":
                    try:
                        results.append(fut.result(timeout=max(10.0, _POLL_S)))
                    except TimeoutError:  # its worker died since: Dask computes it again
                        pending[fut] = (job, tries)
                        continue
                    fut.release()
                    continue
                exc = fut.exception() if fut.status == "error" else None
                fut.release()
                if exc is not None and not isinstance(exc, distributed.KilledWorker):
                    error = error or exc  # e.g. a sample without a valid start
                    continue
                why = _killed(exc)
                if tries < MAX_RESUBMITS:
                    _say(
                        f"the job of {job_samples(job)} was lost ({why}); submitting it "
                        f"again ({tries + 1} of {MAX_RESUBMITS})"
                    )
                    submit(job, tries + 1)
                else:
                    error = error or CampaignIncompleteError(
                        f"the job of {job_samples(job)} was lost {MAX_RESUBMITS + 1} times, "
                        f"the last time: {why}"
                    )
            if results:  # the jobs that completed together are stored together
                on_result(merge(results))
            if error is not None:
                raise error


def execute(jobs: Iterable[Job], engine: Engine, on_result: OnResult) -> None:
    """Run ``jobs`` on ``engine`` (module docstring), calling ``on_result`` in this process
    with each finished job's rows.

    Raises:
        CampaignIncompleteError: the engine lost workers it could not replace (the rows
            handed to ``on_result`` so far are those of the jobs that finished).
    """
    if engine.scheduler is not None:
        timeout = NO_WORKER_TIMEOUT_S if engine.worker_timeout is None else engine.worker_timeout
        _dask(jobs, engine.scheduler, on_result, timeout)
    else:
        _local(jobs, engine.workers, on_result)
