"""Figures a paper reader would misread (issue 33 item 6), checked on the matplotlib figures.

Each figure function is called with :func:`redservo.plots.style.save` replaced by a recorder,
so that the figure stays open and its artists (legends, texts, markers, labels) can be read.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from redservo.reproduction import experiments
from redservo.reproduction.base import Runs, run_experiment

LIMIT_HIT = "joint_limit"


@pytest.fixture
def captured(monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, Any]]:
    """Figure file name -> the open figure, instead of writing it."""
    import redservo.plots.style as figstyle

    figs: dict[str, Any] = {}

    def save(fig: Any, path: Path) -> Path:
        figs[Path(path).name] = fig
        return Path(path)

    monkeypatch.setattr(figstyle, "save", save)
    yield figs
    figstyle._plt().close("all")


@pytest.fixture(scope="module")
def gaze() -> Runs:
    return run_experiment(experiments()["cm01-gaze"], fast=True)


@pytest.fixture(scope="module")
def mc05() -> Runs:
    return run_experiment(experiments()["mc05-joint-limits"], fast=True)


def _renderer(fig: Any) -> Any:
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _legends_off_the_axes(fig: Any) -> None:
    """Every legend lies outside every axes' data region, in at least 8 pt."""
    r = _renderer(fig)
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert legends
    for leg in legends:
        box = leg.get_window_extent(r)
        for ax in fig.axes:
            assert not box.overlaps(ax.get_window_extent(r)), ax.get_title()
        assert min(t.get_fontsize() for t in leg.get_texts()) >= 8


def _marker_lines(ax: Any, marker: str) -> list[Any]:
    return [ln for ln in ax.get_lines() if ln.get_marker() == marker and len(ln.get_xdata()) == 1]


def test_fig9_cross_only_on_the_axis_that_hit(gaze: Runs, captured: dict[str, Any]) -> None:
    from redservo.reproduction.cm01_gaze_figures import figures

    with pytest.MonkeyPatch.context() as mp:  # the saturation sweep is not looked at here
        import redservo.reproduction.cm01_gaze_figures as mod

        mp.setattr(mod, "_saturation_sweep", lambda runs, path: path)
        figures(gaze, Path("unused"))
    fig = captured["fig09_gpm_axes_1_5.png"]
    q1, q5 = fig.axes[0], fig.axes[1]
    hits = [r for r in gaze.results.values() if r.outcome == LIMIT_HIT]
    assert hits and all(r.summary["limit_hit"]["axis"] == 0 for r in hits)  # axis 1 hit
    assert _marker_lines(q1, "x") and not _marker_lines(q5, "x")
    texts = [t.get_text() for t in q1.texts]
    assert any("run ends: axis 1 at its limit" in t for t in texts)
    legend = [t.get_text() for t in q5.get_legend().get_texts()]
    assert any("run ends" in t and "limit" in t for t in legend)  # the | marker explained


def test_fig11_every_run_distinguishable_legend_off_data(
    gaze: Runs, captured: dict[str, Any]
) -> None:
    from redservo.reproduction.cm01_gaze_figures import ITERATIVE, _axes_figure

    _axes_figure(gaze, ITERATIVE, Path("fig11.png"), "CM01 Fig. 11")
    fig = captured["fig11.png"]
    for ax in fig.axes:
        runs = [ln for ln in ax.get_lines() if ln.get_label() in ITERATIVE]
        styles = {(str(ln.get_linestyle()), ln.get_marker()) for ln in runs}
        assert len(runs) == len(ITERATIVE) == len(styles)
    _legends_off_the_axes(fig)


def test_mc05_fig2_units_and_markers_explained(mc05: Runs, captured: dict[str, Any]) -> None:
    from redservo.reproduction.mc05_joint_limits_figures import _fig2

    _fig2(mc05, Path("out"), (0, 1))
    fig = captured["fig2_joint_trajectories.png"]
    plane, time = fig.axes[0], fig.axes[1]
    assert plane.get_xlabel().endswith("(m)") and plane.get_ylabel().endswith("(m)")
    assert "(s)" in time.get_xlabel() and "no unit" in time.get_ylabel()
    legend = {t.get_text() for t in plane.get_legend().get_texts()}
    for ln in plane.get_lines():  # every end marker has its legend entry
        if len(ln.get_xdata()) == 1:
            assert ln.get_label() in legend
    assert any("at its limit" in t for t in legend)
    _legends_off_the_axes(fig)


def test_mc05_fig4_classical_end_annotated(mc05: Runs, captured: dict[str, Any]) -> None:
    from redservo.reproduction.mc05_joint_limits_figures import _fig4

    assert mc05["classical"].outcome == LIMIT_HIT
    _fig4(mc05, Path("out"))
    fig = captured["fig4_features.png"]
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert any("at its limit, run stopped" in t and t.startswith("classical") for t in texts)
    assert all(_marker_lines(ax, "x") for ax in fig.axes)  # the end on every feature
    _legends_off_the_axes(fig)


def test_cm01_fig18_legends_readable_and_off_data(captured: dict[str, Any]) -> None:
    from redservo.reproduction.cm01_humanoid_tracking import figures

    runs = run_experiment(experiments()["cm01-humanoid-tracking"], fast=True)
    figures(runs, Path("out"))
    fig = captured["fig18_humanoid_tracking.png"]
    _legends_off_the_axes(fig)
    legend = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().texts]
    assert "classical, until its limit hit" in legend and "first constrained" in legend
