"""The independent reachability check (issue 34 item 5) and its campaign report."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from redservo.campaign import load_campaign
from redservo.campaign.reach import reachable
from redservo.campaign.reach_check import disagreements, reachable_independent
from redservo.campaign.reach_report import ReachCheck, check_campaign, write_reach_check
from redservo.campaign.sampling import draw_sample
from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario


def _panda(*assignments: str) -> Any:
    return build(apply_overrides(load_scenario("panda-4points"), list(assignments)))


def test_agrees_on_a_reachable_pose() -> None:
    exp = _panda()  # the scenario's own goal, met by its nominal run
    assert reachable(exp) is True
    assert reachable_independent(exp) is True


def test_agrees_on_an_unreachable_pose() -> None:
    exp = _panda("task.desired_pose.translation=[0.0, 0.0, 3.0]")  # 3 m away: out of reach
    assert reachable(exp) is False
    assert reachable_independent(exp, seeds=8) is False  # every start fails: fewer suffice


def test_a_margin_can_make_a_reachable_goal_unreachable() -> None:
    exp = _panda()
    assert reachable_independent(exp, margin=0.45, seeds=8) is False  # joints in the middle 10 %
    assert reachable(exp, margin=0.45) is False


@pytest.mark.parametrize(("sample", "expected"), [(0, True), (2, False)])
def test_agrees_on_moment_samples(sample: int, expected: bool) -> None:
    # mc05-joint-limits, seed 0: the Afma6 moment task, sample 0 reachable, sample 2 not.
    exp = build(draw_sample(load_campaign("mc05-joint-limits"), 0, sample).scenario)
    assert reachable(exp) is expected
    assert reachable_independent(exp, seeds=32 if expected else 8) is expected


def test_no_desired_pose_is_unknown() -> None:
    exp = build(load_scenario("afma6-gaze-demo"))
    assert reachable_independent(exp) is None


def test_disagreements_list_only_judged_differences() -> None:
    got = disagreements([3, 4, 5, 6], [True, False, None, True], [True, True, False, False])
    assert got == [(4, False, True), (6, True, False)]


def test_campaign_report_lists_disagreements(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import redservo.campaign.reach_check as rc

    defn = load_campaign("panda-near-limits")
    rows = [
        {"sample": 0, "method": "classical", "reachable": "True"},
        {"sample": 0, "method": "gpm", "reachable": "True"},
        {"sample": 1, "method": "classical", "reachable": "False"},
        {"sample": 2, "method": "classical", "reachable": ""},  # unknown: not judged
    ]
    monkeypatch.setattr(rc, "reachable_independent", lambda exp: True)
    check = check_campaign(defn, 0, rows)
    assert (check.checked, check.reachable, check.reachable_independent) == (2, 1, 2)
    assert check.disagreements == [(1, False, True)]
    (tmp_path / "campaign.md").write_text("# campaign\n")
    (tmp_path / "campaign.json").write_text(json.dumps({"campaign": "x"}))
    write_reach_check(tmp_path, check)
    md = (tmp_path / "campaign.md").read_text()
    assert "## Reachability check" in md and "| 1 | False | True |" in md
    meta = json.loads((tmp_path / "campaign.json").read_text())
    assert meta["campaign"] == "x"
    assert meta["reach_check"]["agree"] == 1
    assert meta["reach_check"]["disagreements"] == [
        {"sample": 1, "reachable": False, "reachable_independent": True}
    ]


def test_cli_check_reach(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from redservo.cli.entry import main

    path = tmp_path / "c.toml"
    path.write_text(
        'scenario = "panda-4points"\nmethods = ["classical"]\n'
        "[overrides]\nsimulation = { max_iterations = 5 }\n"
    )
    out = tmp_path / "out"
    args = ["campaign", str(path), "--samples", "2", "--workers", "1", "--out", str(out), "-q"]
    assert main([*args, "--check-reach"]) == 0
    assert "## Reachability check" in capsys.readouterr().out
    meta = json.loads((out / "campaign.json").read_text())
    assert meta["reach_check"]["checked"] == 2
    assert "## Reachability check" in (out / "campaign.md").read_text()


def test_reach_check_cpu_is_reported() -> None:
    check = ReachCheck(4, 2, 2, [], 2.0)
    assert check.to_dict()["cpu_s_per_sample"] == pytest.approx(0.5)
    assert np.isclose(check.to_dict()["agree"], 4)
