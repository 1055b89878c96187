"""Paper-ready figures: formats, 300 dpi, one colour per method, units, titles, nothing clipped."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="figures need matplotlib (redservo[plot])")

from redservo import figstyle, plots
from redservo.errors import ConfigurationError
from redservo.experiment import build
from redservo.redundancy import METHODS
from redservo.scenario import parse_scenario
from tests.test_scenario import GOOD


@pytest.fixture
def checked(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Every figure saved through redservo.figstyle.savefig (what plots.save and every
    figure module call), checked before it is written:
    laid out as savefig lays it out, its tight bounding box stays inside the figure, every
    labelled axis has a unit in parentheses and a title."""
    seen: list[Any] = []
    original = figstyle.savefig

    def savefig(fig: Any, stem: Any, formats: Any = None) -> list[Path]:
        if fig.get_layout_engine() is None:
            fig.tight_layout()
        assert not plots.clipped(fig), f"{stem}: a label reaches outside the figure"
        for ax in fig.axes:
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                assert not label or ("(" in label and ")" in label), f"{stem}: no unit: {label!r}"
        titles = [ax.get_title() for ax in fig.axes] + [fig.get_suptitle()]
        assert any(titles), f"{stem}: no title"
        seen.append((Path(stem).stem, titles))
        return original(fig, stem, formats)

    monkeypatch.setattr(figstyle, "savefig", savefig)
    return seen


def test_every_method_has_its_own_colour() -> None:
    colours = [plots.method_style(m)["color"] for m in METHODS]
    assert len(set(zip(colours, [plots.method_style(m)["linestyle"] for m in METHODS]))) == len(
        METHODS
    )
    assert plots.method_style("gpm α=2")["color"] == plots.method_style("gpm")["color"]
    assert plots.method_style("no such method", 3)["color"]


def test_formats_are_checked() -> None:
    assert plots.parse_formats("PNG, pdf,svg") == ("png", "pdf", "svg")
    with pytest.raises(ConfigurationError, match="--format: unknown figure format 'jpg'"):
        plots.parse_formats("png,jpg")


def test_savefig_writes_each_format_at_300_dpi(tmp_path: Path) -> None:
    from PIL import Image

    plt = plots._plt()
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel("a very long x label that would be clipped by a small figure (m)")
    paths = plots.savefig(fig, tmp_path / "f.png", ("png", "pdf", "svg"))
    assert [p.name for p in paths] == ["f.png", "f.pdf", "f.svg"]
    dpi = Image.open(paths[0]).info["dpi"]
    assert round(dpi[0]) == 300
    assert paths[1].read_bytes().startswith(b"%PDF")
    with plots.figure_formats(("svg",)):
        fig, _ = plt.subplots()
        assert plots.save(fig, tmp_path / "g.png").name == "g.svg"
    with plots.figure_formats(()):
        fig, _ = plt.subplots()
        assert plots.savefig(fig, tmp_path / "h") == []


def test_run_and_compare_figures_have_units_titles_and_fit(
    tmp_path: Path, checked: list[Any]
) -> None:
    data = tomllib.loads(GOOD)
    data["simulation"]["max_iterations"] = 40
    exp = build(parse_scenario(data, "mine"))
    results = {m: exp.run(method=m) for m in ("classical", "gpm")}
    plots.run_figures(results["gpm"], exp, tmp_path / "run")
    plots.compare_figures(results, exp, tmp_path / "cmp")
    names = {name for name, _ in checked}
    assert {"joints", "error", "joint_velocities", "camera_velocities", "image"} <= names
    run_titles = " ".join(t for name, titles in checked[:5] for t in titles)
    assert "mine [gpm]" in run_titles


def test_campaign_figures_name_n_and_the_methods(tmp_path: Path, checked: list[Any]) -> None:
    from redservo.campaign.stats import _figures, method_stats

    rows = [
        {"sample": i, "method": m, "success": i % 2 == 0, "iterations": 50 + i, "outcome": "x"}
        for i in range(6)
        for m in ("classical", "iterative-smooth")
    ]
    for r in rows:
        r["outcome"] = "converged" if r["success"] else "joint_limit"
        r.update(
            limit_axis=None if r["success"] else 0,
            min_margin=0.05,
            max_joint_speed=0.1,
            max_cam_translation=0.1,
            max_cam_rotation=0.1,
            discontinuity=0.01,
            final_error=1e-4,
            shield_activations=0,
            velocity_violations=0,
            acceleration_violations=0,
            peak_velocity_ratio=np.nan,
            flags="",
        )
    stats = [
        method_stats(m, [r for r in rows if r["method"] == m])
        for m in ("classical", "iterative-smooth")
    ]
    paths = _figures(stats, rows, tmp_path, name="demo")
    assert [p.name for p in paths] == ["success_rate.png", "iterations.png"]
    titles = " ".join(t for _, ts in checked for t in ts)
    assert "Campaign demo" in titles and "N = 6" in titles
