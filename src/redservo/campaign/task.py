"""A campaign's unit of work: the :class:`Job`, and the runs it makes (wherever it executes).

A job holds a few samples and, for each, the methods still to run. It draws its samples
itself (a sample depends only on ``(definition, seed, index)``), builds each sample's
experiment once, runs its methods (on the compiled loop of :mod:`redservo.campaign.fastloop`
when it applies) and returns the rows. The engines of :mod:`redservo.campaign.engine` only
decide *where* :func:`run_job` executes; this module imports none of them, nor the package
``redservo.campaign`` itself.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import Any, NamedTuple

from redservo.campaign.definition import CampaignDefinition
from redservo.campaign.rows import FAST_PATH, _error_columns, _sample_columns, _summary_columns
from redservo.scenario import Scenario

__all__ = [
    "FAST_PATH",
    "Job",
    "JobResult",
    "fallback_lines",
    "job_samples",
    "make_jobs",
    "merge",
    "run_job",
]

_DEFS: dict[str, CampaignDefinition] = {}
"""Definitions unpickled in this worker, by fingerprint (their ``nominal`` computed once)."""


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


def job_samples(job: Job) -> str:
    """The samples of a job as the user reads them (``"sample 4"``, ``"samples 4-7"``)."""
    ids = [i for i, _ in job.samples]
    if len(ids) == 1:
        return f"sample {ids[0]}"
    if ids == list(range(ids[0], ids[0] + len(ids))):
        return f"samples {ids[0]}-{ids[-1]}"
    return "samples " + ", ".join(map(str, ids))


def _definition(job: Job) -> CampaignDefinition:
    defn = _DEFS.get(job.key)
    if defn is None:
        if len(_DEFS) > 8:
            _DEFS.clear()
        defn = _DEFS[job.key] = job.definition
    return defn


class _Task(NamedTuple):
    sample: int
    method: str
    data: dict[str, Any]
    source: str
    law_options: dict[str, Any] | None
    params: dict[str, Any]
    exp: Any = None
    """The sample's built experiment, shared by its methods (None: built here)."""
    fast: bool = False
    """Try the compiled loop first (:mod:`redservo.campaign.fastloop`)."""


def _run_task(task: _Task) -> dict[str, Any]:
    """Run one (sample, method) and return its row; an exception becomes an ``error`` row.

    The row's ``_path`` says whether the compiled loop ran it (:data:`FAST_PATH`) or why
    not (the job removes it and counts it).
    """
    from redservo.experiment.build import build

    row: dict[str, Any] = {"sample": task.sample, "method": task.method, **task.params}
    try:
        exp = task.exp if task.exp is not None else build(Scenario(task.data, task.source))
        summary, row["_path"] = None, ASKED
        if task.fast and not exp.timing.perfect:  # the compiled loop has no camera timing
            row["_path"] = "camera timing"
        elif task.fast:
            from redservo.campaign.fastloop import fast_run

            summary, row["_path"] = fast_run(exp, task.method, task.law_options)
        if summary is None:
            summary = exp.run(method=task.method, law_options=task.law_options).summary
        # The fields as a plain mapping (RunSummary["flags"] would build the whole dict form).
        fields = {name: getattr(summary, name) for name in summary}
        row.update(_summary_columns(fields, exp.robot.joint_names))
    except Exception as exc:  # recorded, counted as a failure, retried on the next rerun
        row.update(_error_columns(exc))
    return row


def run_job(job: Job) -> JobResult:
    """Run a job's samples and methods; a run that raises becomes an ``error`` row.

    The runs go through this module's ``_run_task`` (looked up at call time, so that a test
    can replace it).

    Raises:
        ScenarioError: a sample has no valid start (the whole campaign stops, as before).
    """
    from redservo.kernels.blas import one_blas_thread

    with one_blas_thread():  # the compiled loop and search: one BLAS thread (kernels/blas.py)
        return _run_samples(job)


def _run_samples(job: Job) -> JobResult:
    """:func:`run_job`'s runs (its BLAS pinned)."""
    from redservo.campaign.sampling import draw_built

    defn = _definition(job)
    joint_names = defn.nominal.joint_names
    rows: list[dict[str, Any]] = []
    paths: Counter[tuple[str, str]] = Counter()
    for i, methods in job.samples:
        s, exp = draw_built(defn, job.seed, i)  # exp None: each run builds again, records why
        params = _sample_columns(s, joint_names)
        params["reachable"] = _reachable(exp)
        for m in methods:
            opts = defn.method_options.get(m)
            task = _Task(
                i,
                m,
                s.scenario.data,
                s.scenario.source,
                dict(opts) if opts is not None else None,
                params,
                exp,
                job.fast,
            )
            row = _run_task(task)
            path = row.pop("_path", None)
            if path is not None:
                paths[(m, str(path))] += 1
            rows.append(row)
    return JobResult(rows, dict(paths))


def _reachable(exp: Any) -> str:
    """The ``reachable`` column of a sample: ``"True"``, ``"False"``, or ``""`` (no desired
    pose, or no experiment) (:mod:`redservo.campaign.reach`)."""
    from redservo.campaign.reach import reachable

    try:
        ok = None if exp is None else reachable(exp)
    except Exception:  # the column is then unknown; the runs themselves are unaffected
        ok = None
    return "" if ok is None else str(bool(ok))


def merge(results: Sequence[JobResult]) -> JobResult:
    """One result of several jobs that finished together (stored in one atomic write)."""
    rows = [row for r in results for row in r.rows]
    paths: Counter[tuple[str, str]] = Counter()
    for r in results:
        paths.update(r.paths)
    return JobResult(rows, dict(paths))


ASKED = "fast=False asked for"
"""The ``_path`` note of a run the caller sent to the object path (no line is printed)."""


def fallback_lines(paths: dict[tuple[str, str], int]) -> list[str]:
    """One line per reason some runs left the compiled loop: the methods and the count."""
    by_reason: dict[str, dict[str, int]] = {}
    for (method, path), count in paths.items():
        if path not in (FAST_PATH, ASKED):
            by_reason.setdefault(path, {})
            by_reason[path][method] = by_reason[path].get(method, 0) + count
    return [
        f"{sum(ms.values())} run(s) of {', '.join(ms)} on the object path, not the compiled "
        f"loop: {reason}"
        for reason, ms in sorted(by_reason.items())
    ]
