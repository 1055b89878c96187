"""The robustness sweep (``reproduce --robustness N``), the check objects, the report and the
cross-comparison table, on the cheapest experiment with the quick settings."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from redservo.cli.entry import main
from redservo.reproduction import experiments
from redservo.reproduction.base import Runs, RunSpec, nominal_scenario, run_experiment
from redservo.reproduction.checks import IMPL, PAPER, Check, Verdict, registrar
from redservo.reproduction.perturbation import (
    DEPTH_SCALE,
    START_SHIFT,
    START_TURN_DEG,
    TARGET_SHIFT,
    draw_perturbation,
)
from redservo.reproduction.robustness import run_robustness, run_setup
from redservo.reproduction.robustness_tally import SetupResult, aggregate

CHEAP = "mc05-joint-limits"


# --------------------------------------------------------------------------- perturbations


def test_draws_are_deterministic_and_within_their_ranges() -> None:
    a = draw_perturbation(CHEAP, 3, seed=7)
    assert a == draw_perturbation(CHEAP, 3, seed=7)
    assert a != draw_perturbation(CHEAP, 4, seed=7)
    assert a != draw_perturbation(CHEAP, 3, seed=8)
    assert a != draw_perturbation("cm01-gaze", 3, seed=7)
    assert all(abs(v) <= TARGET_SHIFT for v in a.target_shift)
    assert DEPTH_SCALE[0] <= a.depth_scale <= DEPTH_SCALE[1]
    assert a.period in (0.04, 0.08)
    # The switches do not change the other draws.
    b = draw_perturbation(CHEAP, 3, seed=7, periods=None, pixel_noise=False)
    assert b.period is None and b.noise_px is None
    assert b.target_shift == a.target_shift and b.depth_scale == a.depth_scale


def test_a_perturbation_moves_the_start_and_the_targets_only() -> None:
    spec = experiments()["mc05-occlusion"]
    base = nominal_scenario(spec)
    p = draw_perturbation("mc05-occlusion", 0, periods=(0.04,), pixel_noise=False)
    bound = p.bind(base)
    from redservo.experiment.build import build

    nominal = build(base)
    moved = build(bound.apply(base))
    dq = moved.q0 - nominal.q0
    steps = np.array(
        [
            START_SHIFT if t == "prismatic" else math.radians(START_TURN_DEG)
            for t in nominal.robot.joint_types
        ]
    )
    assert np.all(np.abs(dq) <= steps + 1e-12) and np.any(dq != 0)
    shift = moved.scene.wMo("target", 0.0)[:3, 3] - nominal.scene.wMo("target", 0.0)[:3, 3]
    assert 0 < np.linalg.norm(shift) <= TARGET_SHIFT * math.sqrt(3) + 1e-12
    # The occluder is not a target: it keeps its world pose although the start moved.
    np.testing.assert_allclose(
        moved.scene.wMo("obstacle", 0.0), nominal.scene.wMo("obstacle", 0.0), atol=1e-12
    )
    # Period 40 ms instead of 40 ms: same duration; depth error applied.
    assert moved.options.dt == 0.04
    assert moved.options.max_iterations == nominal.options.max_iterations
    assert moved.options.depth_scale == pytest.approx(p.depth_scale)


def test_run_setup_evaluates_every_check() -> None:
    r = run_setup(CHEAP, 0, 0, True, False, False)
    assert not r.error and r.perturbation is not None
    assert set(r.verdicts) == {c.name for c in experiments()[CHEAP].checks}


def test_pixel_noise_uses_the_image_sensor() -> None:
    pytest.importorskip("cv2", reason="the image sensor needs OpenCV (redservo[vision])")
    p = draw_perturbation(CHEAP, 1, periods=None)
    assert p.noise_px is not None
    runs = run_experiment(experiments()[CHEAP], fast=True, perturbation=p)
    from redservo.vision import ImageSensor

    assert isinstance(runs.experiments["directional"].sensor, ImageSensor)
    assert runs.perturbation is p


# --------------------------------------------------------------------------- the sweep


def test_sweep_does_not_depend_on_the_number_of_workers() -> None:
    spec = experiments()[CHEAP]
    one = run_robustness(
        [spec], 2, workers=1, seed=1, fast=True, pixel_noise=False, factors=["all"]
    )
    two = run_robustness(
        [spec], 2, workers=2, seed=1, fast=True, pixel_noise=False, factors=["all"]
    )
    assert [c.to_dict() for c in one.checks] == [c.to_dict() for c in two.checks]
    assert [s.verdicts for s in one.setups] == [s.verdicts for s in two.setups]
    assert one.n == 2 and all(c.n == 2 for c in one.checks)


def _setup(i: int, ok: bool, period: float) -> SetupResult:
    return SetupResult(CHEAP, i, {"period": period}, {"classical-ends-in-limit": ok}, 0.1)


def test_categories_and_wilson_intervals() -> None:
    spec = experiments()[CHEAP]
    name = "classical-ends-in-limit"
    setups = [_setup(i, i < 19, 0.04 if i % 2 else 0.08) for i in range(20)]
    rows = aggregate([spec], setups, {(CHEAP, name): True})
    row = next(r for r in rows if r.name == name)
    assert (row.holds, row.n, row.category) == (19, 20, "robust")  # lower bound 0.76
    lo, hi = row.interval
    assert 0.7 < lo < 0.95 < hi <= 1.0
    assert row.by_period == {"40": [9, 10], "80": [10, 10]}
    assert row.failing == {"all": [19]}
    rows = aggregate([spec], setups[11:], {(CHEAP, name): True})  # 8/9: 0.57-0.98
    assert next(r for r in rows if r.name == name).category == "inconclusive"
    few = [_setup(i, i < 3, 0.04) for i in range(20)]  # 3/20: upper bound 0.36
    rows = aggregate([spec], few, {(CHEAP, name): True})
    assert next(r for r in rows if r.name == name).category == "fragile"
    rows = aggregate([spec], setups, {(CHEAP, name): False})
    assert next(r for r in rows if r.name == name).category == "not reproduced"
    # A check missing from a set-up (the set-up failed) counts as not holding.
    other = next(r for r in rows if r.name == "directional-succeeds")
    assert other.holds == 0 and other.n == 20


def test_bad_sweep_arguments() -> None:
    with pytest.raises(ValueError, match="n and unfiltered must be"):
        run_robustness([experiments()[CHEAP]], 0)
    with pytest.raises(ValueError, match="n and unfiltered must be"):
        run_robustness([experiments()[CHEAP]], 1, unfiltered=-1)
    with pytest.raises(ValueError, match="workers"):
        run_robustness([experiments()[CHEAP]], 1, workers=0)


# --------------------------------------------------------------------------- checks


def test_registrar_refuses_duplicates_and_unknown_kinds() -> None:
    checks: list[Check] = []
    check = registrar(checks)

    @check("a", PAPER, "A holds")
    def _a(runs: Runs) -> Verdict:
        return Verdict(True, {"x": 1})

    with pytest.raises(ValueError, match="duplicate"):
        check("a", IMPL, "again")
    with pytest.raises(ValueError, match="kind"):
        check("b", "opinion", "no")  # type: ignore[arg-type]
    assert [c.name for c in checks] == ["a"]
    assert _a(Runs({}, {})).holds  # the function is returned unchanged


def test_a_check_that_cannot_be_computed_does_not_hold() -> None:
    def broken(runs: Runs) -> Verdict:
        return Verdict(bool(runs["missing"]))

    claim = Check("broken", "text", IMPL, broken)(Runs({}, {}))
    assert not claim.reproduced and claim.kind == IMPL
    assert "could not be computed" in claim.note and claim.evidence["error"] == "KeyError"


# --------------------------------------------------------------------------- report and CLI


def test_reproduce_with_robustness_from_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("matplotlib", reason="the reproduction draws figures")
    out = tmp_path / "out"
    argv = ["reproduce", "--only", CHEAP, "--fast", "--robustness", "1", "--workers", "1"]
    code = main([*argv, "--no-pixel-noise", "--seed", "3", "--out", str(out), "-q"])
    printed = capsys.readouterr().out
    assert code == 0
    report = json.loads((out / "report.json").read_text())
    rob = report["robustness"]
    assert rob["n"] == 1 and rob["seed"] == 3 and rob["pixel_noise"] is False
    # --fast keeps each period and --no-pixel-noise drops the image factors
    assert rob["factors"] == ["target shift", "target turn", "start", "depth", "all"]
    paper = [c for c in report["experiments"][0]["claims"] if c["kind"] == PAPER]
    assert report["paper_claims"]["total"] == len(paper) == 3
    md = (out / "report.md").read_text()
    assert "## Robustness" in md and "robustness |" in md
    assert "### Implementation checks" in md and "### Paper claims, per factor" in md
    assert "Generated by `redservo reproduce --only mc05-joint-limits --fast --robustness 1" in md
    ps = report["paper_statements"]
    assert printed.startswith(f"reproduced {ps['reproduced']}/3 distinct paper statements")
    weak = [c for c in rob["checks"] if c["kind"] == PAPER and c["category"] != "robust"]
    for c in weak:  # every non-robust paper claim is named on the console
        assert " ".join(c["claim"].split()) in printed
    assert "robustness over 1 perturbed set-ups per experiment and factor" in printed


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--robustness", "-1"], "robustness must be >= 0"),
        (["--robustness", "1", "--workers", "0"], "workers must be >= 1"),
        (["--only", "mc05-joint-limits,nope"], "unknown experiment 'nope'"),
    ],
)
def test_bad_reproduce_options(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    pytest.importorskip("matplotlib", reason="the reproduction draws figures")
    code = main(["reproduce", *argv, "--out", str(tmp_path / "o")])
    assert code == 2
    assert message in capsys.readouterr().err


def test_cross_comparison_table(monkeypatch: pytest.MonkeyPatch) -> None:
    from redservo.reproduction import cross

    task = cross.Task("mc05-joint-limits", "MC05")
    monkeypatch.setattr(cross, "TASKS", (task,))
    spec = experiments()["cross-comparison"]
    runs = run_experiment(
        type(spec)(
            id="x",
            title="x",
            paper="x",
            scenario="cm01-gaze",
            runs=cross._runs(),
            figures=spec.figures,
        )
    )
    assert all(isinstance(r, RunSpec) and r.scenario == "mc05-joint-limits" for r in cross._runs())
    text = cross.table(runs)
    row = next(line for line in text.splitlines() if line.startswith("| `mc05-joint-limits`"))
    cells = [c.strip() for c in row.split("|")[3:-1]]
    # A full-rank task leaves the iterative scheme no null space: it meets the limit as
    # classical does; the directional operator (κ = 10) converges.
    assert cells[0].startswith("**limit**") and cells[1].startswith("**limit**")
    assert cells[4].startswith("✓")
    assert "What each method does better" in text
