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
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from redservo.campaign.complete import CampaignIncompleteError, incomplete_message, missing_runs
from redservo.campaign.definition import CampaignDefinition
from redservo.campaign.engine import Engine, JobResult, execute, fallback_lines, make_jobs
from redservo.campaign.stats import (
    MethodStats,
    _figures,
    _heading,
    flag_table,
    method_stats,
    stats_table,
)
from redservo.campaign.storage import _Store

__all__ = ["CampaignResult"]

Rows = dict[tuple[int, str], dict[str, Any]]


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
            columns).
        stats: :class:`MethodStats` per method.
        computed: Rows computed by this call (the others were reused from ``out``).
        out: Output directory, or None.
        figures: Paths of the written figures.
        markdown: Heading, the statistics table and notes (``campaign.md``).
    """

    definition: CampaignDefinition
    seed: int
    samples: int
    methods: tuple[str, ...]
    rows: tuple[dict[str, Any], ...]
    stats: dict[str, MethodStats]
    computed: int
    out: Path | None
    figures: tuple[Path, ...]
    markdown: str

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

    Raises:
        CampaignIncompleteError: a (sample, method) has no row at the end (module docstring).
    """
    done: Rows = {
        key: row
        for key, row in (store.rows.items() if store else ())
        if key[0] < n and key[1] in names and row["outcome"] != "error"
    }
    todo = [(i, m) for i in range(n) for m in names if (i, m) not in done]
    bar = _bar(len(todo), defn.name, progress)
    errors: list[str] = []
    stored = dict(store.rows) if store is not None else {}
    paths: dict[tuple[str, str], int] = {}
    computed = 0

    def on_result(res: JobResult) -> None:
        nonlocal computed
        for key, count in res.paths.items():
            paths[key] = paths.get(key, 0) + count
        batch = res.rows
        if store is not None:
            store.append(batch)
            batch = [store.normalize(row) for row in batch]
        for row in batch:
            done[(row["sample"], row["method"])] = stored[(row["sample"], row["method"])] = row
            if row["outcome"] == "error":
                errors.append(f"sample {row['sample']} {row['method']}: {row['error']}")
        computed += len(batch)
        bar(len(batch))

    n_todo = len({i for i, _ in todo})
    jobs = make_jobs(defn, seed, todo, fast=engine.fast, per_job=engine.per_job(n_todo))
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
    missing = missing_runs(done, n, names)
    result = _report(defn, names, n, seed, done, computed, out_dir)
    if out_dir is not None and store is not None:
        result = _write(result, out_dir, store, stored.values())
    if missing:
        reason = str(stopped) if stopped is not None else None
        message = incomplete_message(defn.name, missing, n * len(names), names, out_dir, reason)
        raise CampaignIncompleteError(message, missing=missing, result=result) from stopped
    return result


def _report(
    defn: CampaignDefinition,
    names: tuple[str, ...],
    n: int,
    seed: int,
    done: Rows,
    computed: int,
    out_dir: Path | None,
) -> CampaignResult:
    """The result of the rows present, its statistics and ``campaign.md``'s text."""
    order = {m: k for k, m in enumerate(names)}
    rows = tuple(
        sorted(
            (r for (i, m), r in done.items() if i < n and m in order),
            key=lambda r: (r["sample"], order[r["method"]]),
        )
    )
    stats = {m: method_stats(m, [r for r in rows if r["method"] == m]) for m in names}
    markdown = (
        _heading(defn, n, seed, rows, names)
        + stats_table(stats.values())
        + "\n\nRuns in which each diagnostic flag occurred (docs/safety.md):\n\n"
        + flag_table(stats.values())
    )
    return CampaignResult(defn, seed, n, names, rows, stats, computed, out_dir, (), markdown)


def _write(result: CampaignResult, out_dir: Path, store: _Store, stored: Any) -> CampaignResult:
    """Write the figures (complete campaigns only), ``campaign.json``, ``campaign.md`` and
    ``samples.parquet``; return the result with its figures."""
    defn = result.definition
    if result.complete:
        tracking = not defn.scenario.data.get("simulation", {}).get("stop_at_convergence", True)
        figures = _figures(
            list(result.stats.values()), result.rows, out_dir, tracking=tracking, name=defn.name
        )
        result = replace(result, figures=figures)
    meta = {**result.to_dict(), "written": datetime.now(UTC).isoformat()}
    (out_dir / "campaign.json").write_text(json.dumps(meta, indent=2) + "\n")
    (out_dir / "campaign.md").write_text(result.markdown)
    if store.write_parquet(stored, meta["fingerprint"]) is None:
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
