"""Help choosing a law (issue 32): a run that failed at a limit says which laws take another
path, from their documented approach and the campaigns' numbers (docs/results.md)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import redservo
from redservo.cli.entry import main
from redservo.records.advice import (
    APPROACHES,
    SHIELD_RUNS,
    alternatives,
    compare_hint,
    failed_at_a_limit,
    law_hint,
)

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGNS = ("panda-near-limits", "cm01-gaze", "mc05-joint-limits", "cm01-humanoid-tracking")


def _results_shield_runs(text: str) -> dict[str, tuple[int, int]]:
    """(shield runs, runs) per method summed over the campaigns' tables of docs/results.md
    (each (campaign, method) counted once: its first table)."""
    seen: dict[tuple[str, str], tuple[int, int]] = {}
    campaign: str | None = None
    cols: tuple[int, int] | None = None
    for line in text.splitlines():
        if line.startswith("#"):
            m = re.fullmatch(r"#+ (?:Campaign )?(\S+)", line.strip())
            campaign = m.group(1) if m and m.group(1) in CAMPAIGNS else None
            cols = None
            continue
        if not line.startswith("|") or campaign is None:
            cols = None
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if "shield runs" in cells:
            cols = (cells.index("success [95% CI]"), cells.index("shield runs"))
        elif cols is not None and not set(cells[0]) <= set("-:"):
            runs = re.match(r"\d+/(\d+)", cells[cols[0]])
            assert runs is not None, line
            seen.setdefault((campaign, cells[0]), (int(cells[cols[1]]), int(runs.group(1))))
    out: dict[str, tuple[int, int]] = {}
    for (_, method), (k, n) in seen.items():
        a, b = out.get(method, (0, 0))
        out[method] = (a + k, b + n)
    return out


def test_the_numbers_are_the_results_pages() -> None:
    assert SHIELD_RUNS == _results_shield_runs((ROOT / "docs" / "results.md").read_text())
    assert set(APPROACHES) == set(redservo.METHODS) == set(SHIELD_RUNS)


def test_alternatives_take_another_approach_and_needed_the_shield_less() -> None:
    assert alternatives("iterative-smooth") == [
        "gpm-auto",
        "wln",
        "sns",
        "qp",
        "qp-goal",
        "predictive",
    ]
    for method in redservo.METHODS:
        for other in alternatives(method):
            assert APPROACHES[other] not in (APPROACHES[method], "none")
    assert alternatives("qp") == ["qp-goal", "predictive"]  # never needed the shield either


def test_only_a_failure_at_a_limit_gets_a_hint() -> None:
    base = {"outcome": "converged", "success": True, "min_margin": 0.2, "min_margin_required": 0.01}
    assert law_hint(base, "gpm", "x") is None
    lost = {**base, "success": False, "outcome": "target_lost"}
    assert not failed_at_a_limit(lost) and law_hint(lost, "gpm", "x") is None
    for why in ({"shield_activations": 2}, {"outcome": "joint_limit"}, {"min_margin": 0.001}):
        assert failed_at_a_limit({**base, "success": False, **why}), why


def test_an_unreachable_goal_is_said_instead_of_laws() -> None:
    failed = {"outcome": "converged", "success": False, "shield_activations": 4}
    line = law_hint(failed, "gpm", "x", reachable=False)
    assert line is not None and "no law can succeed here" in line and "--methods" not in line


def test_compare_suggests_only_the_laws_it_did_not_run() -> None:
    ok = {"outcome": "converged", "success": True}
    rode = {"outcome": "converged", "success": False, "shield_activations": 9}
    line = compare_hint({"iterative-smooth": rode, "qp": ok}, "s.toml")
    assert line is not None and line.startswith("hint: iterative-smooth failed at a limit;")
    assert ": gpm-auto, wln, sns, qp-goal, predictive; try them: " in line
    assert line.endswith(
        "redservo compare s.toml --methods iterative-smooth,qp,gpm-auto,wln,sns,qp-goal,predictive "
        "(docs/choosing-a-law.md)"
    )
    assert compare_hint({"qp": ok}, "s.toml") is None
    everything = {m: rode for m in redservo.METHODS}
    assert compare_hint(everything, "s.toml") is None  # nothing left to suggest


def _near_limit(tmp_path: Path) -> Path:
    """The Panda from its URDF, joint 3 started 2.4 % of its range off its lower limit: the
    scenario's law (iterative-smooth) rides the shield (315 steps) and is no success."""
    pytest.importorskip("pinocchio", reason="the URDF scenarios need redservo[urdf] (pin)")
    text = (Path(redservo.__file__).parent / "scenarios" / "panda-urdf-4points.toml").read_text()
    start = "q0 = [0.0, -0.785, 0.0, -2.8, 0.0, 1.571, 0.785]"
    assert start in text
    path = tmp_path / "near.toml"
    path.write_text(text.replace(start, start.replace("-2.8", "-3.0")))
    return path


def test_a_urdf_compare_where_the_laws_ride_the_shield_suggests_the_others(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _near_limit(tmp_path)
    argv = ["compare", str(path), "--methods", "iterative-smooth,gpm", "--no-plot", "-q"]
    assert main([*argv, "--out", str(tmp_path / "c")]) == 0
    hints = [line for line in capsys.readouterr().err.splitlines() if line.startswith("hint:")]
    assert hints == [
        "hint: iterative-smooth, gpm failed at a limit; laws not compared here that keep off the "
        "limits another way and needed the shield in fewer campaign runs (docs/results.md): "
        f"gpm-auto, iterative, wln, sns, qp, qp-goal, predictive; try them: redservo compare "
        f"{path} --methods iterative-smooth,gpm,gpm-auto,iterative,wln,sns,qp,qp-goal,predictive "
        "(docs/choosing-a-law.md)"
    ]


def test_a_urdf_run_that_rides_the_shield_suggests_laws_and_the_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _near_limit(tmp_path)
    assert main(["run", str(path), "--no-plot", "-q", "--out", str(tmp_path / "o")]) == 0
    captured = capsys.readouterr()
    assert (
        "no success: iteration cap reached (500 iterations) before convergence; the shield "
        "acted at 315 step(s)" in captured.out
    ), captured.out
    hints = [line for line in captured.err.splitlines() if line.startswith("hint:")]
    assert len(hints) == 1, captured.err
    assert hints[0].startswith(
        "hint: iterative-smooth needed the position shield; the goal is reachable"
    )
    assert (
        "gpm-auto (31 %), wln (34 %), sns (0 %), qp (0 %), qp-goal (0 %), predictive (0 %)"
        in hints[0]
    )
    command = (
        f"redservo compare {path} --methods iterative-smooth,gpm-auto,wln,sns,qp,qp-goal,predictive"
    )
    assert command in hints[0], hints[0]
