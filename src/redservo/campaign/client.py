"""The client side of a campaign: it runs the engine, stores every row, checks that no run is
missing and writes the report.

Only this process stores rows (docs/campaigns.md, "Storage"); the engines of
:mod:`redservo.campaign.engine` hand it each finished job. At the end it counts the rows of
every ``(sample, method)`` asked for (:mod:`redservo.campaign.complete`): when any is missing,
the report states the N actually completed per method and
:class:`~redservo.campaign.complete.CampaignIncompleteError` names the missing runs.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from redservo.campaign.complete import CampaignIncompleteError, incomplete_message, missing_runs
from redservo.campaign.definition import CampaignDefinition
from redservo.campaign.engine import (
    FAST_PATH,
    Engine,
    Job,
    JobResult,
    execute,
    fallback_lines,
    make_jobs,
)
from redservo.campaign.figures import campaign_figures
from redservo.campaign.rowfile import (
    RowFile,
    RowView,
    remove_with,
    temporary_file,
)
from redservo.campaign.rows import _columns, stored
from redservo.campaign.stats import MethodStats, _heading, flag_table, stats_table
from redservo.campaign.storage import _Store
from redservo.campaign.table import RunTable

__all__ = ["CampaignResult"]

_BLOCK = 256
"""Jobs made at a time (each of ``Engine.per_job`` samples)."""


@dataclass(frozen=True)
class CampaignResult:
    """The rows and per-method statistics of a campaign.

    Attributes:
        definition: The campaign definition.
        seed: The seed.
        samples: Number of samples N requested (``stats[m].runs``: the rows method ``m``
            actually has; fewer only in the ``result`` of a
            :class:`~redservo.campaign.complete.CampaignIncompleteError`).
        methods: Methods, in table order.
        rows: One dict per (sample, method), sorted by sample then method (``samples.csv``
            columns): a sequence (:class:`~redservo.campaign.rowfile.RowView`) that reads
            each row back from ``samples.csv`` (without ``out``: a temporary file, removed
            with the result) when asked, so a campaign of any N holds no row in memory
            (docs/scaling.md, "Memory"); slices are tuples.
        stats: :class:`MethodStats` per method.
        computed: Rows computed by this call (the others were reused from ``out``).
        out: Output directory, or None.
        figures: Paths of the written figures.
        markdown: Heading, the statistics table and notes (``campaign.md``).
        engines: Per method, how many of the runs computed by this call took the compiled
            loop (``"compiled loop"``) or the object path (keyed by the reason).
    """

    definition: CampaignDefinition
    seed: int
    samples: int
    methods: tuple[str, ...]
    rows: Sequence[dict[str, Any]]
    stats: dict[str, MethodStats]
    computed: int
    out: Path | None
    figures: tuple[Path, ...]
    markdown: str
    engines: dict[str, dict[str, int]] = field(default_factory=dict)

    @property
    def complete(self) -> bool:
        """Every method has a row for each of the ``samples`` samples."""
        return all(s.runs == self.samples for s in self.stats.values())

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``campaign.json``); NaN becomes None."""

        def clean(v: Any) -> Any:
            return None if isinstance(v, float) and math.isnan(v) else v

        d = self.definition
        return {
            "campaign": d.name,
            "source": d.source,
            "scenario": d.scenario.source,
            "seed": self.seed,
            "samples": self.samples,
            "completed": {m: s.runs for m, s in self.stats.items()},
            "complete": self.complete,
            "methods": list(self.methods),
            "engine": self.engines,
            "fingerprint": d.fingerprint(self.seed),
            "success": (
                "converged, every joint at least min_margin from its limits all along, no "
                "velocity or acceleration limit exceeded, and the position shield never acted"
            ),
            "stats": {
                m: {k: clean(v) for k, v in s._asdict().items()} for m, s in self.stats.items()
            },
        }


def run(
    defn: CampaignDefinition,
    names: tuple[str, ...],
    n: int,
    seed: int,
    engine: Engine,
    out_dir: Path | None,
    store: _Store | None,
    progress: bool,
) -> CampaignResult:
    """The body of :func:`redservo.campaign.run_campaign`, with the output directory locked.

    No row is kept as a dict (docs/scaling.md, "Memory"): each finished row goes to the
    store's ``samples.csv`` (or, without an output directory, a temporary file) and its
    values to a :class:`~redservo.campaign.table.RunTable`; ``CampaignResult.rows`` reads
    the rows back from the file.

    Raises:
        CampaignIncompleteError: a (sample, method) has no row at the end (module docstring).
    """
    table = RunTable(names, n)
    folder: Path | None = None
    append: Callable[[Sequence[Mapping[str, Any]]], Any]
    if store is not None:
        assert store.file is not None
        rowfile, index, append = store.file, store.index, store.append
        for row in store.stored_rows():  # one pass over the file, no row kept
            if table.wants(row["sample"], row["method"]) and row["outcome"] != "error":
                table.add(row)
    else:  # no output directory: the rows go to a temporary file, removed with the result
        rowfile, folder = temporary_file(_columns(defn.nominal.joint_names))
        index = {}

        def spill(batch: Sequence[Mapping[str, Any]]) -> None:
            for row, offset in zip(batch, rowfile.append(batch)):
                index[(int(row["sample"]), str(row["method"]))] = offset

        append = spill

    try:
        computed, stopped, paths = _execute(defn, seed, engine, append, table, progress)
        missing = missing_runs(table, n, names)
        view = _view(rowfile, index, table)
    finally:
        if store is None:
            rowfile.close()
    if folder is not None:
        remove_with(view, folder)
    result = _report(defn, names, n, seed, table, view, computed, out_dir)
    engines: dict[str, dict[str, int]] = {}
    for (method, path), count in sorted(paths.items()):
        engines.setdefault(method, {})[path] = count
    result = replace(result, engines=engines, markdown=result.markdown + _engine_note(engines))
    if out_dir is not None and store is not None:
        result = _write(result, out_dir, store, table)
    if missing:
        reason = str(stopped) if stopped is not None else None
        message = incomplete_message(defn.name, missing, n * len(names), names, out_dir, reason)
        raise CampaignIncompleteError(message, missing=missing, result=result) from stopped
    return result


def _execute(
    defn: CampaignDefinition,
    seed: int,
    engine: Engine,
    append: Callable[[Sequence[Mapping[str, Any]]], Any],
    table: RunTable,
    progress: bool,
) -> tuple[int, CampaignIncompleteError | None, dict[tuple[str, str], int]]:
    """Run the pairs ``table`` has no row for on ``engine``, handing each finished batch of
    rows to ``append`` (the file) and their values, as they read back from it, to ``table``.
    Returns the number of rows computed, the error that stopped the engine (lost workers)
    and how many runs of each method took each path; says on stderr which runs fell back
    and which failed."""
    missing = ~table.present
    bar = _bar(int(missing.sum()), defn.name, progress)
    errors: list[str] = []
    paths: dict[tuple[str, str], int] = {}
    computed = 0
    columns = _columns(defn.nominal.joint_names)

    def on_result(res: JobResult) -> None:
        nonlocal computed
        for key, count in res.paths.items():
            paths[key] = paths.get(key, 0) + count
        batch = res.rows
        append(batch)
        for raw in batch:
            row = stored(columns, raw)  # the values its line reads back as
            if table.wants(row["sample"], row["method"]):
                table.add(row)
            if row["outcome"] == "error":
                errors.append(f"sample {row['sample']} {row['method']}: {row['error']}")
        computed += len(batch)
        bar(len(batch))

    n_todo = int(missing.any(axis=0).sum())
    jobs = _jobs(defn, seed, table, engine.fast, engine.per_job(n_todo))
    stopped: CampaignIncompleteError | None = None
    try:
        execute(jobs, engine._replace(workers=min(engine.workers, max(1, n_todo))), on_result)
    except CampaignIncompleteError as exc:  # lost workers: report what is there, then raise
        stopped = exc
    finally:
        bar(None)
    for line in fallback_lines(paths):
        print(f"redservo campaign: {line}", file=sys.stderr)
    for msg in errors:
        print(f"redservo campaign: run failed with an exception: {msg}", file=sys.stderr)
    return computed, stopped, paths


def _engine_note(engines: dict[str, dict[str, int]]) -> str:
    """The ``campaign.md`` line saying where this call's runs ran (compiled loop or not)."""
    fast = sum(c for paths in engines.values() for p, c in paths.items() if p == FAST_PATH)
    other = {
        p: [m for m, paths in engines.items() if p in paths]
        for paths in engines.values()
        for p in paths
        if p != FAST_PATH
    }
    text = f"\n\nEngine: {fast} run(s) computed by this call on the compiled loop"
    for reason, methods in other.items():
        n = sum(engines[m][reason] for m in methods)
        text += f"; {n} run(s) of {', '.join(methods)} on the object path ({reason})"
    return text + ".\n"


def _jobs(
    defn: CampaignDefinition, seed: int, table: RunTable, fast: bool, per_job: int
) -> Iterator[Job]:
    """The jobs of the pairs ``table`` has no row for, made a block of samples at a time (so
    the list of pairs to run is never held whole: docs/scaling.md, "Memory")."""
    block = per_job * _BLOCK
    for start in range(0, table.n, block):
        todo = [
            (i, m)
            for i in range(start, min(start + block, table.n))
            for m in table.methods
            if (i, m) not in table
        ]
        if todo:
            yield from make_jobs(defn, seed, todo, fast=fast, per_job=per_job)


def _view(rowfile: RowFile, index: dict[tuple[int, str], int], table: RunTable) -> RowView:
    """The rows of ``table`` (sorted by sample, then method order) read back from the file."""
    samples, methods = table.pairs()
    offsets = np.fromiter(
        (index[(int(i), table.methods[k])] for i, k in zip(samples, methods)),
        dtype=np.int64,
        count=samples.size,
    )
    return RowView(
        rowfile.path, rowfile.columns, offsets, samples, methods, table.methods, rowfile.seal
    )


def _report(
    defn: CampaignDefinition,
    names: tuple[str, ...],
    n: int,
    seed: int,
    table: RunTable,
    rows: RowView,
    computed: int,
    out_dir: Path | None,
) -> CampaignResult:
    """The result of the rows present, its statistics and ``campaign.md``'s text."""
    stats = {m: table.stats(m) for m in names}
    markdown = (
        _heading(defn, n, seed, table.counts(), table.redraws())
        + stats_table(stats.values())
        + "\n\nRuns in which each diagnostic flag occurred (docs/safety.md):\n\n"
        + flag_table(stats.values())
    )
    return CampaignResult(defn, seed, n, names, rows, stats, computed, out_dir, (), markdown)


def _write(result: CampaignResult, out_dir: Path, store: _Store, table: RunTable) -> CampaignResult:
    """Write the figures (complete campaigns only), ``campaign.json``, ``campaign.md`` and
    ``samples.parquet``; return the result with its figures."""
    defn = result.definition
    if result.complete:
        tracking = not defn.scenario.data.get("simulation", {}).get("stop_at_convergence", True)
        figures = campaign_figures(
            list(result.stats.values()),
            (),
            out_dir,
            tracking=tracking,
            name=defn.name,
            box=table.box(tracking),
        )
        result = replace(result, figures=figures)
    meta = {**result.to_dict(), "written": datetime.now(UTC).isoformat()}
    (out_dir / "campaign.json").write_text(json.dumps(meta, indent=2) + "\n")
    (out_dir / "campaign.md").write_text(result.markdown)
    if store.write_parquet(meta["fingerprint"]) is None:
        store.notify("samples.parquet not written: pip install 'redservo[parquet]'")
    return result


def _bar(total: int, desc: str, enabled: bool) -> Callable[[int | None], None]:
    """Return ``update(k)`` for a tqdm bar on stderr; ``update(None)`` closes it."""
    if not enabled or total == 0:
        return lambda _k: None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is an optional extra
        return lambda _k: None
    bar = tqdm(total=total, desc=desc, unit="run", file=sys.stderr, disable=None, leave=False)

    def update(k: int | None) -> None:
        if k is None:
            bar.close()
        else:
            bar.update(k)

    return update
