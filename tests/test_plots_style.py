"""Paper-ready figures: formats, 300 dpi, one colour per method, units, titles, nothing clipped."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="figures need matplotlib (redservo[plot])")

from redservo.errors import ConfigurationError
from redservo.experiment.build import build
from redservo.plots import figures as plots
from redservo.plots import style as figstyle
from redservo.redundancy import METHODS
from redservo.scenario import parse_scenario
from tests.test_scenario import GOOD


@pytest.fixture
def checked(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Every figure saved through redservo.plots.style.savefig (what plots.save and every
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
        assert not legend_hides_data(fig), f"{stem}: a legend hides data"
        titles = [ax.get_title() for ax in fig.axes] + [fig.get_suptitle()]
        assert any(titles), f"{stem}: no title"
        seen.append((Path(stem).stem, titles))
        return original(fig, stem, formats)

    monkeypatch.setattr(figstyle, "savefig", savefig)
    return seen


def legend_hides_data(fig: Any) -> bool:
    """True when a legend's box (display pixels) covers a data point of its axes."""
    fig.canvas.draw()
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None:
            continue
        box = leg.get_window_extent()
        xy = figstyle._data_in_axes(ax)
        if not len(xy):
            continue
        pix = ax.transAxes.transform(xy)
        inside = (
            (pix[:, 0] >= box.x0)
            & (pix[:, 0] <= box.x1)
            & (pix[:, 1] >= box.y0)
            & (pix[:, 1] <= box.y1)
        )
        if inside.any():
            return True
    return False


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
    from redservo.campaign.figures import campaign_figures
    from redservo.campaign.stats import method_stats

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
    paths = campaign_figures(stats, rows, tmp_path, name="demo")
    assert [p.name for p in paths] == ["success_rate.png", "iterations.png"]
    titles = " ".join(t for _, ts in checked for t in ts)
    assert "Campaign demo" in titles and "N = 6" in titles


def test_a_legend_goes_to_a_free_corner_or_outside() -> None:
    plt = plots._plt()
    fig, ax = plt.subplots(figsize=(5, 3))
    t = np.linspace(0.0, 1.0, 50)
    ax.plot(t, 1.0 - 0.5 * t, label="falls")  # upper left to the middle right
    ax.plot(t, 0.05 + 0.1 * t, label="low")  # along the bottom, both lower corners
    ax.plot([0.95], [0.95], "o", label="corner")  # upper right
    leg = figstyle.place_legend(ax)
    assert leg._loc != 0 and not legend_hides_data(fig)
    fig2, ax2 = plt.subplots(figsize=(5, 3))
    for y in (0.0, 1.0):
        ax2.plot(t, np.full_like(t, y), label=f"y={y}")  # every corner has data
    figstyle.place_legend(ax2)
    fig2.tight_layout()  # as savefig does
    fig2.canvas.draw()
    assert ax2.get_legend().get_window_extent().x0 >= ax2.get_window_extent().x1
    assert not plots.clipped(fig2)
    plt.close(fig)
    plt.close(fig2)


def test_each_role_has_one_colour_in_figures_videos_and_the_viewer() -> None:
    """The current and desired features, the target: one colour each, from figstyle."""
    from redservo.viewer import animate, image, server
    from redservo.vision import video

    assert video._CURRENT == image._CUR == figstyle.role_rgb("current")
    assert video._DESIRED == image._DES == figstyle.role_rgb("desired")
    assert server.TARGET_COLOR == image._OBJ == video._DOT == figstyle.role_rgb("target")
    assert animate._TARGET == figstyle.ROLE_COLORS["target"]
    assert figstyle.role_rgb("desired") == (230, 159, 0)
    with pytest.raises(ConfigurationError, match="unknown colour role 'x'; roles: current"):
        figstyle.role_rgb("x")


def test_the_video_draws_current_and_desired_in_their_colours() -> None:
    pytest.importorskip("cv2", reason="videos need OpenCV (redservo[vision])")
    from redservo.camera import Camera
    from redservo.vision.optics import Optics
    from redservo.vision.video import compose_frame

    img = np.full((240, 320), 128, np.uint8)
    cam = Camera(width=320, height=240, px=400.0, py=400.0, u0=160.0, v0=120.0)
    rgb = compose_frame(
        img, Optics(cam, 0.0, 0.0), detected=np.array([0.1, 0.1]), desired=np.array([-0.1, 0.0])
    )
    for role in ("current", "desired"):
        near = np.all(np.abs(rgb.astype(int) - figstyle.role_rgb(role)) < 20, axis=2)
        assert near.sum() > 20, role


@pytest.mark.parametrize(
    "errors",
    [
        np.geomspace(0.3, 1e-5, 40),
        np.linspace(-0.5, 250.0, 40),
        np.full(40, 0.02),
        np.r_[np.nan, np.geomspace(1e4, 1e-8, 39)],
        np.full(40, np.nan),
    ],
    ids=["decades", "linear", "constant", "nan-wide", "all-nan"],
)
@pytest.mark.parametrize("size", [(240, 200), (480, 320)])
def test_no_label_of_the_video_error_panel_is_clipped(
    errors: np.ndarray, size: tuple[int, int]
) -> None:
    """Every tick label and caption of the --video error panel lies inside the panel, the
    tick labels left of the plot box, and no two labels overlap (bounding boxes)."""
    pytest.importorskip("cv2", reason="videos need OpenCV (redservo[vision])")
    from redservo.vision.videopanel import error_panel, panel_layout

    h, w = size
    for k in (0, 20, 39):
        lay = panel_layout(errors, k, h, w)
        x0, y0, x1, y1 = lay.box
        assert 0 < x0 < x1 <= w and 0 < y0 < y1 <= h
        boxes = [b for _, _, b in lay.texts]
        for text, _, (a, b, c, d) in lay.texts:
            assert 0 <= a and c <= w and 0 <= b and d <= h, (text, (a, b, c, d), size)
        for (yv, label), (_, _, box) in zip(lay.ticks, lay.texts):
            assert box[2] < x0 and y0 - 1 <= yv <= y1 + 1, label
        for i, p in enumerate(boxes):
            for q in boxes[i + 1 :]:
                assert p[2] <= q[0] or q[2] <= p[0] or p[3] <= q[1] or q[3] <= p[1], (p, q)
        assert error_panel(errors, k, h, w).shape == (h, w, 3)
