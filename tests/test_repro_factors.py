"""Per-factor robustness, honest labels and realistic imaging of ``redservo reproduce`` (tiny
sweeps, the cheapest experiment, quick settings)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import redservo.reproduction as repro
from redservo.reproduction import PAPER, experiments
from redservo.reproduction.base import Runs
from redservo.reproduction.checks import IMPL, Claim
from redservo.reproduction.perturbation import (
    FACTORS,
    FOCAL_ERROR,
    NOISE_PX,
    draw_perturbation,
)
from redservo.reproduction.report import ExperimentResult, statements
from redservo.reproduction.robustness import run_robustness
from redservo.reproduction.robustness_tally import (
    CheckRobustness,
    SetupResult,
    aggregate,
    categorize,
)

CHEAP = "mc05-joint-limits"


# --------------------------------------------------------------------------- one factor at a time


def test_a_single_factor_moves_that_factor_only_with_the_value_all_uses() -> None:
    every = draw_perturbation(CHEAP, 2, seed=5)
    assert every.factor == "all" and every.noise_px is not None
    assert 0.0 <= every.noise_px <= NOISE_PX[1] and NOISE_PX[1] >= 10.0
    assert abs(every.focal_scale - 1.0) <= FOCAL_ERROR and every.blur_px > 0.0
    alone = {f: draw_perturbation(CHEAP, 2, seed=5, factor=f) for f in FACTORS}
    assert alone["depth"].depth_scale == every.depth_scale
    assert alone["depth"].target_shift == (0.0, 0.0, 0.0) and alone["depth"].period is None
    assert alone["depth"].noise_px is None  # no image: the ideal sensor
    assert alone["target shift"].target_shift == every.target_shift
    assert alone["target shift"].depth_scale == 1.0
    assert alone["period"].period == every.period
    assert alone["focal"].focal_scale == every.focal_scale
    assert alone["focal"].noise_px == 0.0 and alone["focal"].blur_px == 0.0
    assert alone["noise"].noise_px == every.noise_px and alone["noise"].focal_scale == 1.0
    assert alone["blur"].blur_px == every.blur_px and alone["blur"].noise_px == 0.0
    with pytest.raises(ValueError, match="factor must be one of"):
        draw_perturbation(CHEAP, 0, factor="wind")


def test_tiny_per_factor_sweep() -> None:
    spec = experiments()[CHEAP]
    rob = run_robustness(
        [spec], 1, fast=True, pixel_noise=False, workers=1, factors=("depth", "all")
    )
    assert rob.factors == ("depth", "all") and {s.factor for s in rob.setups} == {"depth", "all"}
    for c in rob.checks:
        assert set(c.by_factor) == {"depth", "all"} and c.n == 1
    d = rob.to_dict()
    assert d["factors"] == ["depth", "all"]
    assert {"by_factor", "broken_by", "weakest_factor"} <= set(d["checks"][0])
    with pytest.raises(ValueError, match="not available"):
        run_robustness([spec], 1, fast=True, pixel_noise=False, factors=("noise",))


def _rows(holds: dict[str, int], n: int = 20) -> list[SetupResult]:
    return [
        SetupResult(CHEAP, i, {"period": None}, {"directional-succeeds": i < k}, 0.1, "", f)
        for f, k in holds.items()
        for i in range(n)
    ]


def test_categories_are_decided_on_the_interval_and_the_breaking_factor_is_named() -> None:
    spec = experiments()[CHEAP]
    assert categorize(True, (0.84, 1.0)) == "robust"
    assert categorize(True, (0.5, 0.9)) == "inconclusive"
    assert categorize(True, (0.3, 0.6)) == "fragile"
    assert categorize(False, (0.9, 1.0)) == "not reproduced"

    def row(holds: dict[str, int]) -> CheckRobustness:
        rows = aggregate([spec], _rows(holds), {(CHEAP, "directional-succeeds"): True})
        return next(r for r in rows if r.name == "directional-succeeds")

    r = row({"depth": 20, "start": 8, "period": 15, "all": 19})
    assert r.category == "robust"  # 19/20: Wilson lower bound 0.76 >= 0.7
    assert r.breaking == ["start"] and r.weakest == "start"
    assert row({"depth": 20, "all": 17}).category == "inconclusive"  # 0.64-0.95 contains 0.7
    assert row({"depth": 20, "all": 9}).category == "fragile"  # upper bound 0.66 < 0.7
    whole = row({"depth": 20, "all": 20})
    assert whole.breaking == [] and whole.weakest is None


# --------------------------------------------------------------------------- labels


SETUP_CHECKS = {
    "cm01-gaze": ("classical-hits-axis-1", "gpm-auto-early-transient"),
    "cm01-cylinder": ("classical-hits-a-limit",),
    "cm01-humanoid-tracking": ("small-tracking-error",),
    "mc05-joint-limits": ("classical-ends-in-limit", "not-slowed", "rank-not-null-near-limits"),
    "mc05-occlusion": (
        "no-avoidance-occluded",
        "classical-projector-occluded",
        "features-unmodified-after",
    ),
}


def test_set_up_outcomes_and_consequences_are_not_paper_claims() -> None:
    specs = experiments()
    for exp_id, names in SETUP_CHECKS.items():
        for name in names:
            assert specs[exp_id].check(name).kind == IMPL, (exp_id, name)


def _result(exp_id: str, verdict: bool) -> ExperimentResult:
    spec = experiments()[exp_id]
    claims = [
        Claim(c.text, verdict, {}, name=c.name, kind=c.kind, statement=c.statement or c.name)
        for c in spec.checks
    ]
    return ExperimentResult(spec, Runs({}, {}), claims, [])


def test_duplicates_are_counted_once() -> None:
    gaze = experiments()["cm01-gaze"]
    assert gaze.check("gpm-auto-axis-1-then-5-current").statement == "gpm-auto-axis-1-then-5"
    results = [_result(e, True) for e in ("cm01-gaze", "mc05-joint-limits", "mc05-optical-axis")]
    st = statements(results)
    checks = sum(c.kind == PAPER for e in results for c in e.claims)
    # one gpm-auto rule and the three claims re-checked on the optical-axis start
    assert len(st) == checks - 1 - 3
    assert len(st[("mc05-joint-limits", "mainly-an")]) == 2
    # A statement that fails in one variant is not counted as reproduced in every variant.
    results[1] = _result("mc05-joint-limits", False)
    assert sum(all(v) for v in statements(results).values()) == len(st) - 3


# --------------------------------------------------------------------------- realistic imaging


def test_realistic_image_keeps_the_assumed_camera_for_the_detector() -> None:
    pytest.importorskip("cv2", reason="the image sensor needs redservo[vision] (opencv)")
    from redservo.camera import Camera
    from redservo.reproduction.imaging import REALISTIC, Imaging, image_sensor

    assert 2.0 <= REALISTIC.noise_px <= 5.0 and REALISTIC.k1 != 0.0 and REALISTIC.gradient > 0.0
    sensor = image_sensor(Camera(), Imaging(focal_scale=1.05, k1=-0.05, gradient=0.15))
    r = sensor.renderer
    assert r.optics.camera.px == 600.0 and r.optics.k1 == 0.0  # what the detector uses
    true_cam = r.true_optics.camera  # the lens drawn: the camera's own distortion model
    assert true_cam.px == pytest.approx(630.0) and true_cam.k1 == -0.05
    # the drawn lens moves a point 0.3 normalized units off-centre by k1 r³ (about 0.8 px)
    uv_true, uv_model = r.true_optics.to_pixel([0.3, 0.0]), r.optics.to_pixel([0.3, 0.0])
    assert uv_true[0] - uv_model[0] == pytest.approx(600 * (1.05 * 0.3 * (1 - 0.05 * 0.09) - 0.3))
    img = r.render_layers([]).astype(float)  # the background under the lighting gradient
    assert img[:, :20].mean() < 0.8 * img[:, -20:].mean()
    assert np.all(img >= 0)
    from redservo.errors import ConfigurationError

    with pytest.raises(ConfigurationError, match="gradient"):
        Imaging(gradient=1.5)


def test_reproduce_through_images_runs_the_cross_comparison(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cross-comparison's runs are on other scenarios; through images they used to raise."""
    pytest.importorskip("cv2", reason="the image sensor needs redservo[vision] (opencv)")
    pytest.importorskip("matplotlib", reason="the reproduction draws figures")
    from redservo.reproduction import cross

    spec = experiments()["cross-comparison"]
    label = "mc05-joint-limits / classical"  # meets the limit within a few iterations

    def cell(runs: Runs) -> str:
        return f"cell: {cross._cell(runs[label])}"

    small = dataclasses.replace(
        spec, runs=tuple(r for r in spec.runs if r.label == label), extra=cell
    )
    assert small.runs and small.runs[0].scenario == "mc05-joint-limits"
    monkeypatch.setattr(repro, "experiments", lambda: {"cross-comparison": small})
    out = tmp_path / "rep"
    report = repro.reproduce(out, only="cross-comparison", fast=True, sensor="image")
    assert report["imaging"]["k1"] != 0.0 and report["through_images"] == {}
    md = (out / "report.md").read_text()
    assert "### Through images" in md and "uncorrected lens distortion" in md
    tail = md[md.index("### Through images") :]
    assert "cell: **limit**" in tail
    json.dumps(report, default=str)


def test_robustness_alone_means_twenty_set_ups() -> None:
    from redservo.cli.parser import build_parser

    parser = build_parser()
    assert parser.parse_args(["reproduce", "--robustness"]).robustness == 20
    assert parser.parse_args(["reproduce"]).robustness == 0
    assert parser.parse_args(["reproduce", "--robustness", "3"]).robustness == 3


def test_the_report_names_the_breaking_factor_and_whose_fragility() -> None:
    from redservo.reproduction.report_robustness import robustness_section
    from redservo.reproduction.robustness_tally import Robustness

    spec = experiments()[CHEAP]
    setups = _rows({"start": 5, "depth": 20, "all": 6})
    checks = aggregate(
        [spec], setups, {(CHEAP, "directional-succeeds"): True}, ("start", "depth", "all")
    )
    rob = Robustness(20, 0, False, False, 1, 1.0, checks, setups, ("start", "depth", "all"))
    md = "\n".join(robustness_section(rob, [(CHEAP, "the slice is narrow"), ("other", "x")]))
    assert "| start | depth | all | category |" in md and "**5/20**" in md
    assert "— all factors 6/20 (30 %, 95 % CI 15 %–52 %), fragile;" in md  # numbers first
    assert "broken by start (5/20)" in md
    assert "**`mc05-joint-limits`.** the slice is narrow" in md and "**`other`.**" not in md
