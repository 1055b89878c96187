"""``redservo warmup --jobs N``: the warm-up's parts on N processes at once.

A cold warm-up is hundreds of numba compilations, each on one core. The first part (the
first law) runs alone: it compiles what every part calls (the laws' generated dispatch, the
step, about a third of the whole), which would otherwise be compiled by every worker at
once; beside it run only the groups that call no step (``Group.steps`` False: the
reachability searches). Then N worker processes take the other parts (a law, a scenario, a
campaign: :attr:`redservo.bench.warmup.Group.parts`) from one queue, by the compiled chain
they share: a group that names its chain (``Group.chain``: every campaign runs the one
campaign-loop kernel, every scenario the Controller's) runs its first part (the chain's
head) before its other parts, so that one worker compiles the chain while the other takes
another chain or the other groups; parts are handed out by robot (:func:`family`, one
worker per family) otherwise. The workers share numba's
on-disk cache: a kernel one worker has saved is loaded, not compiled, by the other. Two
workers may still compile the same signature at the same moment (a kernel both chains
call): the work is then done twice, never lost, and numba's cache index keeps every entry
(:mod:`redservo.kernels._cache_lock` serialises its updates).

One line per part done on stderr (its wall seconds and compilations), each worker's numba
progress every 8 s while it compiles, then a line per group and the verdict; the marker of a
complete warm-up is left only when every part ran. Workers are forked (POSIX); elsewhere, or
with N = 1, the parts run in this process (:func:`redservo.bench.warmup.warmup`).
"""

from __future__ import annotations

import multiprocessing
import sys
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import IO, NamedTuple

from redservo.bench.compile_progress import Progress
from redservo.bench.warmup import GROUPS, CompileCounter, Group, WarmupReport, verdict, warmup
from redservo.errors import ConfigurationError

__all__ = ["PartDone", "family", "warmup_jobs"]

_GROUPS: tuple[Group, ...] = GROUPS  # the worker's groups (set before the fork)


class PartDone(NamedTuple):
    """What a worker reports for one part."""

    group: int
    part: str
    seconds: float
    compiled: int
    notes: tuple[str, ...]


def _run_part(group: int, part: str, quiet: bool) -> PartDone:
    """In a worker: run one part, counting its compilations (numba progress on stderr)."""
    g = _GROUPS[group]
    counter = CompileCounter(progress=None if quiet else Progress(f"warmup {part}"))
    installed = counter.install()
    notes: list[str] = []
    t0 = time.perf_counter()
    try:
        if g.run_part is None:
            g.run(notes.append)
        else:
            g.run_part(part, notes.append)
    finally:
        if installed:
            counter.uninstall()
        if counter.progress is not None:
            counter.progress.finish()
    return PartDone(group, part, time.perf_counter() - t0, counter.count, tuple(notes))


def _run_family(tasks: list[tuple[int, str]], quiet: bool) -> list[PartDone]:
    """In a worker: run parts of one family, one after the other."""
    return [_run_part(i, p, quiet) for i, p in tasks]


def family(part: str) -> str:
    """The robot a part is about, the first word of its name (``afma6``, ``panda``, ``cm01``;
    a law's name otherwise): the parts of a family compile mostly the same step chain, so one
    worker runs them (two would compile it at the same time, each)."""
    return part.split("-")[0]


Task = tuple[int, str]
"""A part to run: (index of its group, part name)."""


def _families(tasks: list[Task], heavy: frozenset[str] = frozenset()) -> list[list[Task]]:
    """The tasks by :func:`family`: the families with a ``heavy`` part first
    (:attr:`redservo.bench.warmup.Group.heavy`), then the largest (the queue's long ones)."""
    by: dict[str, list[Task]] = {}
    for task in tasks:
        by.setdefault(family(task[1]), []).append(task)
    return sorted(by.values(), key=lambda f: (not any(t[1] in heavy for t in f), -len(f)))


class _Plan(NamedTuple):
    """The order of the parts on the workers (module docstring)."""

    first: list[Task]
    """The first part, which compiles the step kernel."""
    free: list[list[Task]]
    """The groups that call no step, beside the first part (a chain's parts on one worker)."""
    heads: dict[str, Task]
    """Per compiled chain (:attr:`Group.chain`), the part that compiles it, after the first."""
    chained: dict[str, list[list[Task]]]
    """Per chain, its other parts by family, after its head (they load the chain)."""
    others: list[list[Task]]
    """The other parts by family, after the first part."""


def _plan(tasks: list[Task], groups: tuple[Group, ...]) -> _Plan:
    first, rest = tasks[:1], tasks[1:]
    free: dict[str, list[Task]] = {}
    heads: dict[str, Task] = {}
    chained: dict[str, list[Task]] = {}
    others: list[Task] = []
    for task in rest:
        g = groups[task[0]]
        if not g.steps:
            free.setdefault(g.chain or family(task[1]), []).append(task)
        elif not g.chain:
            others.append(task)
        elif g.chain in heads:
            chained.setdefault(g.chain, []).append(task)
        else:
            heads[g.chain] = task
    heavy = frozenset(part for g in groups for part in g.heavy)
    by_chain = {c: _families(ts, heavy) for c, ts in chained.items()}
    return _Plan(first, list(free.values()), heads, by_chain, _families(others, heavy))


def _tasks(groups: tuple[Group, ...]) -> list[tuple[int, str]]:
    """Every (group index, part), the groups in order (a group without parts: one task)."""
    return [
        (i, part)
        for i, g in enumerate(groups)
        for part in (g.parts() if g.parts is not None else (g.name,))
    ]


def warmup_jobs(
    jobs: int,
    *,
    quiet: bool = False,
    groups: tuple[Group, ...] = GROUPS,
    stream: IO[str] | None = None,
) -> WarmupReport:
    """The warm-up of ``groups`` on ``jobs`` forked processes (module docstring); the report
    gives each group's seconds summed over its parts (CPU-bound: about its CPU time).

    Raises:
        ConfigurationError: ``jobs`` < 1 (``argument="--jobs"``).
    """
    if jobs < 1:
        raise ConfigurationError(f"--jobs must be at least 1, got {jobs}", argument="--jobs")
    from redservo.kernels import compiled

    if jobs == 1 or not compiled() or "fork" not in multiprocessing.get_all_start_methods():
        return warmup(quiet=quiet, groups=groups, stream=stream)
    out = stream or sys.stderr

    def say(text: str) -> None:
        if not quiet:
            print(text, file=out, flush=True)

    global _GROUPS
    _GROUPS = groups
    tasks = _tasks(groups)
    say(f"warmup: {len(tasks)} parts of {len(groups)} groups on {jobs} processes ...")
    report = WarmupReport({g.name: 0.0 for g in groups}, {g.name: 0 for g in groups}, True)
    t0 = time.perf_counter()
    ctx = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
        # The first part alone: it compiles the kernels every part calls (the laws' dispatch,
        # the step), which the others then load from the cache instead of compiling each;
        # beside it only the groups that call no step. Then each chain's head, before the
        # chain's other parts, so that one worker compiles it.
        plan = _plan(tasks, groups)
        head = pool.submit(_run_family, plan.first, quiet)
        pending = {head, *(pool.submit(_run_family, f, quiet) for f in plan.free)}
        chain_of: dict[Future[list[PartDone]], str] = {}
        finished = 0
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                for r in future.result():  # a part that failed raises here, as without --jobs
                    finished += 1
                    _add(report, groups[r.group].name, r, f"{finished}/{len(tasks)}", say)
            if head in done:
                for chain, task in plan.heads.items():
                    chain_of[pool.submit(_run_family, [task], quiet)] = chain
                pending |= set(chain_of) | {pool.submit(_run_family, f, quiet) for f in plan.others}
            for future in done & set(chain_of):
                later = plan.chained.get(chain_of[future], [])
                pending |= {pool.submit(_run_family, f, quiet) for f in later}
    return _finish(report, time.perf_counter() - t0, say)


def _add(report: WarmupReport, name: str, r: PartDone, n: str, say: Callable[[str], None]) -> None:
    """Add a part's seconds and compilations to its group's; its notes and one line (``n``:
    how many parts are done, of how many)."""
    report.seconds[name] += r.seconds
    report.compiled[name] += r.compiled
    for text in r.notes:
        say(f"  {name}: {text}")
    say(f"  [{n}] {name}: {r.part}: {r.seconds:.1f} s, {r.compiled} compiled")


def _finish(report: WarmupReport, wall: float, say: Callable[[str], None]) -> WarmupReport:
    """Each group's totals, the marker of a complete warm-up, the verdict."""
    from redservo.bench.kernel_mode import mark_warm

    for name in report.seconds:
        say(f"  {name}: {report.seconds[name]:.1f} s, {report.compiled[name]} compilation(s)")
    mark_warm()
    say(verdict(report, wall))
    return report
