"""``redservo plot PATH``: re-draw the figures of a saved run, comparison, campaign or
reproduction from its files, without simulating again.

* a run directory (``summary.json`` + ``log.npz``): the run's figures
  (:func:`redservo.plots.figures.draw_run`), with the scenario's camera and thresholds when the
  run holds its resolved ``scenario.toml``;
* a comparison directory (``compare.json``, one run directory per method): the overlaid
  figures (:func:`redservo.plots.figures.draw_compare`);
* a campaign directory (``campaign.json`` + ``samples.csv``): the campaign figures, from
  the stored rows (:func:`redservo.campaign.stats._figures`);
* a reproduction directory (``report.json``): every experiment's paper figures, from the
  saved runs (each run directory holds its scenario).

Figures are written next to the data (or into ``out``, the ``--out`` option) in the active
formats (:func:`redservo.plots.style.figure_formats`, the ``--format`` option). Any other
folder is refused (nothing is written into it).
"""

from __future__ import annotations

import csv
import json
from dataclasses import fields
from pathlib import Path
from typing import Any

from redservo.errors import ConfigurationError
from redservo.runs.load import Run, find_runs, is_run_dir, load_run

__all__ = ["kind_of", "replot", "summary_from_dict"]


def kind_of(path: Path) -> str:
    """``"run"``, ``"compare"``, ``"campaign"`` or ``"reproduction"``.

    Raises:
        ConfigurationError: none of these (the message lists what each needs).
    """
    if is_run_dir(path):
        return "run"
    if (path / "report.json").is_file():
        return "reproduction"
    if (path / "campaign.json").is_file() and (path / "samples.csv").is_file():
        return "campaign"
    if (path / "compare.json").is_file():
        return "compare"
    what = "does not exist" if not path.exists() else "holds none of them"
    inside = [r.relative_to(path).as_posix() for r in find_runs(path)] if path.is_dir() else []
    if inside:
        what += f"; runs inside: {', '.join(inside[:6])}" + (", ..." if len(inside) > 6 else "")
    raise ConfigurationError(
        f"{path}: not a run (summary.json + log.npz), comparison (compare.json), campaign "
        f"(campaign.json + samples.csv) or reproduction (report.json) directory ({what})",
        argument="path",
    )


def replot(path: str | Path, out: str | Path | None = None) -> list[Path]:
    """Re-draw the figures of ``path`` (module docstring); returns the files written.

    Args:
        path: A run, comparison, campaign or reproduction directory.
        out: Where to write the figures (created; default ``path`` itself).

    Raises:
        ConfigurationError: ``path`` is none of these (nothing is written).
    """
    p = Path(path)
    kind = kind_of(p)
    dest = p if out is None else Path(out)
    dest.mkdir(parents=True, exist_ok=True)
    if kind == "run":
        return _run(load_run(p), dest)
    if kind == "compare":
        return _compare(p, dest)
    if kind == "campaign":
        return _campaign(p, dest)
    return _reproduction(p, dest)


def _context(run: Run) -> Any:
    from redservo.plots.figures import FigureContext

    if run.scenario_path is not None:
        return FigureContext.of(run.experiment())
    n = len(run.joint_names)
    return FigureContext(scenario=run.name, joint_names=run.joint_names, joint_units=("-",) * n)


def _run(run: Run, out: Path) -> list[Path]:
    from redservo.plots.figures import draw_run

    return draw_run(run.simulation_log(), _context(run), run.method, out)


def _compare(path: Path, out: Path) -> list[Path]:
    from redservo.plots.figures import draw_compare

    runs = [load_run(p) for p in find_runs(path, depth=1)]
    meta = (
        json.loads((path / "compare.json").read_text()) if (path / "compare.json").is_file() else {}
    )
    order = list(meta.get("methods", {}))
    runs.sort(key=lambda r: order.index(r.method) if r.method in order else len(order))
    if not runs:
        raise ConfigurationError(f"{path}: no run directories inside", argument="path")
    logs = {r.method: r.simulation_log() for r in runs}
    return draw_compare(logs, _context(runs[0]), out)


def _campaign_rows(path: Path) -> list[dict[str, Any]]:
    from redservo.campaign.storage import _columns, _parse

    with open(path / "samples.csv", newline="", encoding="utf-8") as fh:
        records = list(csv.reader(fh))
    header = records[0] if records else []
    joints = [c[3:] for c in header if c.startswith("q0_")]
    kinds = dict(_columns(joints))
    rows = []
    for rec in records[1:]:
        if len(rec) != len(header):
            continue
        try:
            rows.append({c: _parse(v, kinds.get(c, "str")) for c, v in zip(header, rec)})
        except ValueError:
            continue
    return rows


def _campaign(path: Path, out: Path) -> list[Path]:
    from redservo.campaign.figures import campaign_figures
    from redservo.campaign.stats import method_stats

    meta = json.loads((path / "campaign.json").read_text())
    n, methods = int(meta["samples"]), list(meta["methods"])
    rows = [r for r in _campaign_rows(path) if r["sample"] < n and r["method"] in methods]
    stats = [method_stats(m, [r for r in rows if r["method"] == m]) for m in methods]
    tracking = False
    definition = path / "definition.json"
    if definition.is_file():
        scenario = json.loads(definition.read_text()).get("scenario", {})
        tracking = not scenario.get("simulation", {}).get("stop_at_convergence", True)
    return list(
        campaign_figures(stats, rows, out, tracking=tracking, name=str(meta.get("campaign", "")))
    )


def summary_from_dict(data: dict[str, Any]) -> Any:
    """A typed :class:`~redservo.simulation.RunSummary` from ``summary.json``."""
    from redservo.simulation import FlagCount, RunSummary

    names = {f.name for f in fields(RunSummary)}
    kw = {k: v for k, v in data.items() if k in names}
    kw["flags"] = {
        k: FlagCount(int(v["count"]), int(v["first"])) for k, v in kw.get("flags", {}).items()
    }
    return RunSummary(**kw)


def _reproduction(path: Path, out: Path) -> list[Path]:
    from redservo.reproduction import experiments
    from redservo.reproduction.base import Runs
    from redservo.simulation import SimulationResult

    report = json.loads((path / "report.json").read_text())
    specs = experiments()
    written: list[Path] = []
    for entry in report.get("experiments", []):
        spec = specs.get(entry["id"])
        if spec is None:
            continue
        by_label = {}
        for run_dir in find_runs(path / entry["id"] / "runs", depth=1):
            run = load_run(run_dir)
            by_label[str(run.summary.get("label", run_dir.name))] = run
        missing = [label for label in entry.get("runs", {}) if label not in by_label]
        if missing:
            raise ConfigurationError(
                f"{path / entry['id']}: the saved runs lack {missing[:3]}; re-run "
                f"redservo reproduce --only {entry['id']}",
                argument="path",
            )
        results, exps = {}, {}
        for label, run in by_label.items():
            summary = summary_from_dict(run.summary)
            results[label] = SimulationResult(summary.outcome, summary, run.simulation_log())
            exps[label] = run.experiment()
        order = list(entry.get("runs", {}))
        runs = Runs(
            {k: results[k] for k in order if k in results},
            {k: exps[k] for k in order if k in exps},
        )
        (out / entry["id"]).mkdir(parents=True, exist_ok=True)
        written.extend(spec.figures(runs, out / entry["id"]))
    return written
