"""Claims as they are (issue 34): numbers before categories, the docs' table generated from a
run, failures' shared factors found by the sweep, weak statements not counted as paper
claims, unfiltered set-ups, and the project's success margin in every "no limit" check."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from redservo.cli.entry import main
from redservo.records.summary import SUCCESS_MARGIN, clear_of_limits
from redservo.reproduction import experiments
from redservo.reproduction.base import Runs
from redservo.reproduction.checks import IMPL
from redservo.reproduction.claims_table import (
    BEGIN,
    END,
    claim_lines,
    doc_block,
    merge_unfiltered,
    rate_text,
    replace_block,
)
from redservo.reproduction.metrics import succeeded
from redservo.reproduction.perturbation import draw_perturbation
from redservo.reproduction.report import console_summary
from redservo.reproduction.robustness_interactions import best_splits, interaction_text
from redservo.reproduction.robustness_tally import SetupResult, aggregate
from redservo.reproduction.unfiltered import (
    START_TURN_DEG,
    TARGET_SHIFT,
    TARGET_TURN_DEG,
    draw_unfiltered,
)

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "reproduction-robustness.json"
CHEAP = "mc05-joint-limits"


def _check(holds: int, n: int, **extra: Any) -> dict[str, Any]:
    from redservo.campaign.stats import wilson_interval

    col = {"holds": holds, "n": n, "interval": list(wilson_interval(holds, n))}
    return {
        "experiment": "e",
        "name": "c",
        "claim": "the claim",
        "kind": "paper claim",
        "nominal": True,
        "category": "inconclusive",
        "by_factor": {"all": col, **extra},
        "broken_by": [],
        "weakest_factor": None,
    }


# --------------------------------------------------------------------------- 1. numbers first


def test_every_claim_line_gives_k_of_n_and_the_interval_before_the_category() -> None:
    rob = {"checks": [_check(11, 20)]}
    (line,) = claim_lines(rob)
    assert line.startswith("11/20 (95 % CI 34 %–74 %) inconclusive [e] the claim")
    assert rate_text(rob["checks"][0], "unfiltered") == "—"


def test_console_summary_lists_every_paper_claim_with_its_numbers() -> None:
    rob = {
        "n": 20,
        "seconds": 1.0,
        "workers": 2,
        "checks": [_check(11, 20), {**_check(20, 20), "category": "robust", "claim": "other"}],
    }
    report = {
        "paper_statements": {"reproduced": 2, "total": 2},
        "paper_claims": {"reproduced": 2, "total": 2},
        "implementation_checks": {"hold": 0, "total": 0},
        "experiments": [],
        "robustness": rob,
    }
    text = "\n".join(console_summary(report, Path("out")))
    assert "  - 11/20 (95 % CI 34 %–74 %) inconclusive [e] the claim" in text
    assert "  - 20/20 (95 % CI 84 %–100 %) robust [e] other" in text  # robust ones too
    assert text.index("11/20") < text.index("in all: 1 robust, 1 inconclusive")


# --------------------------------------------------------------------------- 2. the docs' table


def test_results_md_table_is_what_the_generator_writes_from_the_committed_run() -> None:
    data = json.loads(DATA.read_text())
    block = "\n".join(doc_block(data["robustness"], data["command"]))
    doc = (ROOT / "docs" / "results.md").read_text()
    assert doc.count(BEGIN) == 1 and doc.count(END) == 1
    assert doc[doc.index(BEGIN) : doc.index(END) + len(END)] == block
    # Every check of every experiment is in it, paper claims and implementation checks.
    for spec in experiments().values():
        for c in spec.checks:
            assert f"| `{spec.id}` | {' '.join(c.text.split())} |" in block, (spec.id, c.name)


def test_replace_block_and_its_errors() -> None:
    text = f"a\n{BEGIN}\nold\n{END}\nb\n"
    assert replace_block(text, [BEGIN, "new", END]) == f"a\n{BEGIN}\nnew\n{END}\nb\n"
    from redservo.errors import ConfigurationError

    with pytest.raises(ConfigurationError, match="no '<!-- BEGIN"):
        replace_block("no markers", [BEGIN, END], "docs/x.md")


def test_generator_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from redservo.reproduction.claims_table import main as table_main

    doc = tmp_path / "doc.md"
    doc.write_text(f"# t\n\n{BEGIN}\n{END}\n")
    assert table_main([str(DATA), "--doc", str(doc)]) == 0
    assert "**Paper claims**" in doc.read_text()
    assert table_main([str(tmp_path / "missing.json")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "missing.json" in err and err.count("\n") == 1


def test_merge_takes_the_unfiltered_column_of_another_run() -> None:
    base = {"command": "a", "robustness": {"checks": [_check(11, 20)], "setups": []}}
    unf = _check(3, 20)["by_factor"]["all"]
    other = {
        "command": "b",
        "robustness": {
            "unfiltered": 20,
            "checks": [{**_check(0, 0), "by_factor": {"unfiltered": unf}}],
            "setups": [{"factor": "unfiltered", "experiment": "e"}],
        },
    }
    merged = merge_unfiltered(base, other)
    (line,) = claim_lines(merged["robustness"])
    assert line.startswith("11/20 (95 % CI 34 %–74 %) inconclusive, unfiltered 3/20 (95 % CI")


# --------------------------------------------------------------------------- 3. what failures share


def _setups(depths: list[float], turns: list[float], fails: list[bool]) -> list[dict[str, Any]]:
    out = []
    for i, (d, t, f) in enumerate(zip(depths, turns, fails, strict=True)):
        p = draw_perturbation(CHEAP, i, pixel_noise=False).to_dict()
        p.update(depth_scale=d, target_turn_deg=(t, 0.0, 0.0), target_shift=(0.0, 0.0, 0.0))
        p.update(start_offsets=(0.0,) * 12, period=0.04)  # the other factors: constant
        out.append({"perturbation": p, "verdicts": {"c": not f}})
    return out


def test_the_sweep_finds_the_factor_and_the_pair_the_failures_share() -> None:
    rng = np.random.default_rng(0)
    depths = list(np.exp(rng.uniform(math.log(0.5), math.log(2.0), 20)))
    turns = list(rng.uniform(0.0, 3.0, 20))
    fails = [d >= 1.3 and t >= 1.0 for d, t in zip(depths, turns, strict=True)]
    setups = _setups(depths, turns, fails)
    splits = best_splits(setups, "c")
    assert splits[0].factor == "depth" and splits[0].above
    assert 1.0 < splits[0].threshold <= 1.3
    assert splits[0].bad[0] == sum(fails) and splits[0].good[0] == 0
    text = interaction_text(setups, "c")
    assert text.startswith(f"{sum(fails)} of 20 all-factors set-ups fail; depth ≥ ×")
    assert "Both (depth ≥" in text and "target turn ≥" in text and "exploratory" in text
    assert interaction_text(_setups(depths, turns, [False] * 20), "c") == ""


# --------------------------------------------------------------------------- 4. weak statements


@pytest.mark.parametrize(
    ("experiment", "name"),
    [
        ("cm01-gaze", "huge-alpha-velocity-peaks"),
        ("cm01-gaze", "smooth-faster-imperfect-robot"),
        ("mc05-occlusion", "features-accelerated"),
    ],
)
def test_near_tautological_statements_are_implementation_checks(experiment: str, name: str) -> None:
    check = next(c for c in experiments()[experiment].checks if c.name == name)
    assert check.kind == IMPL and "not a reproduction" in check.text


# --------------------------------------------------------------------------- 6. unfiltered set-ups


def test_unfiltered_draws_are_deterministic_wide_and_apart_from_the_sweep() -> None:
    a = draw_unfiltered(CHEAP, 2, seed=1)
    assert a == draw_unfiltered(CHEAP, 2, seed=1) and a != draw_unfiltered(CHEAP, 3, seed=1)
    assert a.factor == "unfiltered" and a.noise_px is None and a.period is None
    assert a.depth_scale == 1.0 and all(abs(v) <= TARGET_SHIFT for v in a.target_shift)
    assert all(abs(v) <= TARGET_TURN_DEG for v in a.target_turn_deg)
    assert max(abs(v) for v in a.target_shift) > 0.02  # wider than the perturbed sweep's
    assert a.start_scale[0] * 2.0 == pytest.approx(START_TURN_DEG)
    assert a.target_shift != draw_perturbation(CHEAP, 2, seed=1).target_shift


def test_unfiltered_column_is_tallied_but_never_a_breaking_factor() -> None:
    spec = experiments()[CHEAP]
    name = spec.checks[0].name
    setups = [SetupResult(CHEAP, i, None, {name: True}, 0.0, "", "all") for i in range(20)] + [
        SetupResult(CHEAP, i, None, {name: i < 2}, 0.0, "", "unfiltered") for i in range(20)
    ]
    row = next(
        r
        for r in aggregate([spec], setups, {(CHEAP, name): True}, ("all", "unfiltered"))
        if r.name == name
    )
    assert row.by_factor["unfiltered"] == (2, 20) and row.by_factor["all"] == (20, 20)
    assert row.breaking == [] and row.weakest is None and row.category == "robust"


@pytest.mark.parametrize(
    ("argv", "message"),
    [(["--unfiltered", "-1"], "unfiltered must be >= 0")],
)
def test_bad_unfiltered_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    pytest.importorskip("matplotlib", reason="the reproduction draws figures")
    assert main(["reproduce", *argv, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


# --------------------------------------------------------------------------- 8. the success margin


def _run(outcome: str, margin: float) -> SimpleNamespace:
    return SimpleNamespace(outcome=outcome, summary={"min_margin": margin, "iterations": 10})


def test_no_limit_reached_means_the_success_margin() -> None:
    assert SUCCESS_MARGIN == 0.01
    assert clear_of_limits(0.01 - 1e-12) and not clear_of_limits(0.0035)
    assert succeeded(_run("converged", 0.02))  # type: ignore[arg-type]
    assert not succeeded(_run("converged", 0.0035))  # type: ignore[arg-type]  # CM01 Fig. 18's


@pytest.mark.parametrize(("margin", "holds"), [(0.0035, False), (0.05, True)])
def test_fig18_tracking_check_uses_the_success_margin(margin: float, holds: bool) -> None:
    spec = experiments()["cm01-humanoid-tracking"]
    check = next(c for c in spec.checks if c.name == "tracks-to-the-end")
    runs = Runs(
        {"iterative-smooth": _run("max_iterations", margin), "iterative": _run("converged", 0.2)},
        {},
    )
    claim = check(runs)
    assert claim.reproduced is holds and claim.evidence["required margin"] == SUCCESS_MARGIN


def test_fig17_positioning_check_uses_the_success_margin() -> None:
    spec = experiments()["cm01-humanoid-sphere"]
    check = next(c for c in spec.checks if c.name == "eq27-printed-converges")
    from redservo.reproduction.cm01_humanoid_sphere import EQ27

    assert not check(Runs({EQ27: _run("converged", 0.0035)}, {})).reproduced
    assert check(Runs({EQ27: _run("converged", 0.02)}, {})).reproduced
