"""A campaign's figures: success and shield per method, and the distributions of the run
statistics (box plots), in the house style (:mod:`redservo.plots.style`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from redservo.campaign.stats import MethodStats

__all__ = ["campaign_figures"]


def campaign_figures(
    result_stats: Sequence[MethodStats],
    rows: Sequence[Mapping[str, Any]],
    out: Path,
    *,
    tracking: bool = False,
    name: str = "",
    formats: Sequence[str] | None = None,
    box: Sequence[Sequence[float]] | None = None,
) -> tuple[Path, ...]:
    """Write ``success_rate`` and ``iterations`` (tracking: ``final_error``) figures.

    ``box``: the values of the second figure per method when already known
    (:meth:`redservo.campaign.table.RunTable.box`; ``rows`` is then not read).

    Titles give the campaign ``name`` and N (runs per method); each method has its colour
    of :func:`redservo.plots.style.method_style`; files as :func:`redservo.plots.style.savefig`
    writes them (``formats``: default the active ones). Returns the first file of each.
    """
    try:
        from matplotlib.figure import Figure

        from redservo.plots.style import method_style, savefig
    except ImportError:  # matplotlib is optional
        return ()
    names = [s.method for s in result_stats]
    x = np.arange(len(names))
    colors = [method_style(m, k)["color"] for k, m in enumerate(names)]
    runs = sorted({s.runs for s in result_stats})
    n_text = f"N = {runs[0]}" if len(runs) == 1 else f"N = {runs[0]}-{runs[-1]}"
    head = f"Campaign {name}: " if name else "Campaign: "
    size = (max(6.0, 0.7 * len(names) + 2), 4.2)
    fig = Figure(figsize=size, layout="constrained")
    ax = fig.add_subplot()
    rate = np.array([s.success_rate for s in result_stats]) * 100
    err = np.array(
        [
            [r - 100 * s.ci_low for r, s in zip(rate, result_stats)],
            [100 * s.ci_high - r for r, s in zip(rate, result_stats)],
        ]
    ).clip(min=0.0)  # rounding can make a bound cross p̂ by 1e-15 when p̂ is 0 or 1
    ax.bar(x, rate, yerr=err, capsize=3, color=colors, edgecolor="k", linewidth=0.5)
    ax.set_xticks(x, names, rotation=45, ha="right")
    ax.set_xlabel(f"method ({n_text} runs each)")
    ax.set_ylim(0, 105)
    ax.set_ylabel("success rate (%), 95% Wilson CI")
    ax.set_title(f"{head}success rate, {n_text} runs per method", fontsize=10)
    first = savefig(fig, out / "success_rate", formats)
    if not first:  # figures are off (--no-plot)
        return ()
    fig = Figure(figsize=size, layout="constrained")
    ax = fig.add_subplot()
    data = list(box) if box is not None else _box_data(rows, names, tracking)
    if tracking:  # every run lasts the same: show how well the runs that lasted tracked
        ax.set_yscale("log")
        ax.set_ylabel("final ‖e1‖ (feature units)")
        what, stem = "final error of the runs that lasted", "final_error"
    else:
        ax.set_ylabel("iterations to converge (-)")
        what, stem = "iterations to converge (successes only)", "iterations"
    boxes = ax.boxplot([d if d else [np.nan] for d in data], positions=x, patch_artist=True)
    for patch, color in zip(boxes["boxes"], colors):
        patch.set(facecolor=color, alpha=0.6)
    ax.set_xticks(x, [f"{m}\n(n={len(d)})" for m, d in zip(names, data)], rotation=45, ha="right")
    ax.set_xlabel("method (n = runs shown)")
    ax.set_title(f"{head}{what}, {n_text}", fontsize=10)
    return first[0], savefig(fig, out / stem, formats)[0]


def _box_data(
    rows: Iterable[Mapping[str, Any]], names: Sequence[str], tracking: bool
) -> list[list[float]]:
    """The second figure's values per method: iterations of the successes, or (tracking)
    the final error of the runs that lasted (``converged`` or ``max_iterations``)."""
    data: dict[str, list[float]] = {m: [] for m in names}
    for r in rows:
        if r["method"] not in data:
            continue
        if tracking and r["outcome"] in ("converged", "max_iterations"):
            data[r["method"]].append(r["final_error"])
        elif not tracking and r["success"]:
            data[r["method"]].append(r["iterations"])
    return list(data.values())
