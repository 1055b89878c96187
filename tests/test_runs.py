"""Self-describing runs: the resolved scenario re-runs a run exactly; load_run; plot; replay."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from redservo import load_run
from redservo.cli.entry import main
from redservo.errors import ConfigurationError
from redservo.experiment.build import build
from redservo.runs.tomlwriter import dumps
from redservo.scenario import load_scenario, parse_scenario
from tests.test_scenario import GOOD


def _scenario(tmp_path: Path, text: str = GOOD) -> Path:
    p = tmp_path / "my.toml"
    p.write_text(text)
    return p


def test_toml_writer_round_trips_scenario_values() -> None:
    table = {
        "name": 'a "quoted" name\nwith a newline and ünicode',
        "n": 3,
        "x": 1e-08,
        "big": 1e300,
        "neg": -0.0,
        "flag": True,
        "weird key": [1.5, 2, 3],
        "robot": {"q0": [0.0, -0.785, 1.0], "options": {"tool": "ccmop"}, "rho": 0.1},
        "objects": [
            {"name": "t", "pose": {"translation": [0.1, 0.2, 0.3]}, "points": [[0, 0, 0]]},
            {"name": "s", "kind": "sphere", "motion": {"waypoints": [{"t": 0.0}, {"t": 1.0}]}},
        ],
        "skipped": None,
    }
    back = tomllib.loads(dumps(table, header="line 1\nline 2"))
    table.pop("skipped")
    assert back == table
    assert math.copysign(1.0, back["neg"]) == -1.0


def test_toml_writer_refuses_none_in_arrays() -> None:
    with pytest.raises(ConfigurationError, match="None"):
        dumps({"a": [1, None]})


def test_run_directory_re_runs_exactly(tmp_path: Path) -> None:
    """`redservo run DIR/scenario.toml` reproduces the run bit for bit (issue 14)."""
    out = tmp_path / "run"
    args = ["run", str(_scenario(tmp_path)), "--method", "gpm", "--out", str(out), "-q"]
    assert main([*args, "--set", "control.options.alpha=3.0", "--no-plot"]) == 0
    for name in ("scenario.toml", "run.json", "diagnostics.json", "summary.json", "log.csv"):
        assert (out / name).is_file(), name
    text = (out / "scenario.toml").read_text()
    assert text.startswith("# Resolved scenario of a run written by redservo")
    resolved = tomllib.loads(text)
    assert resolved["control"]["method"] == "gpm"
    assert resolved["control"]["options"] == {"alpha": 3.0, "rcond": 1e-08}
    assert resolved["simulation"]["tolerance"] == 1e-3  # a default, written out
    assert resolved["camera"]["px"] == 600.0
    meta = json.loads((out / "run.json").read_text())
    assert meta["exact"] is True and meta["method"] == "gpm"
    again = tmp_path / "again"
    assert main(["run", str(out / "scenario.toml"), "--out", str(again), "-q", "--no-plot"]) == 0
    a, b = load_run(out), load_run(again)
    assert np.array_equal(a.arrays["q"], b.arrays["q"])
    assert a.summary["outcome"] == b.summary["outcome"]


def test_load_run_gives_a_dataframe_and_the_scenario(tmp_path: Path) -> None:
    pytest.importorskip("pandas", reason="Run.log is a pandas DataFrame")
    out = tmp_path / "r"
    assert main(["run", str(_scenario(tmp_path)), "--out", str(out), "-q", "--no-plot"]) == 0
    run = load_run(out / "summary.json")  # a file inside the directory works too
    assert run.method == "iterative-smooth" and run.name == "mine"
    assert len(run.log) == len(run) == run.summary["iterations"]
    assert {"t", "q[0]", "q[5]", "error_norm", "flag.shield-acted"} <= set(run.log.columns)
    assert run.log.index.name == "iteration"
    assert run.log.attrs["joint_names"] == ["x", "y", "z", "A", "B", "C"]
    assert run.joint_names == ("x", "y", "z", "A", "B", "C")
    assert run.scenario.name == "mine"
    assert run.experiment().robot.n == 6
    assert isinstance(run.diagnostics["flags"], dict)


def test_load_run_explains_what_is_not_a_run(tmp_path: Path) -> None:
    with pytest.raises(ConfigurationError, match="not a run directory"):
        load_run(tmp_path)
    with pytest.raises(ConfigurationError, match="does not exist"):
        load_run(tmp_path / "nope")


def test_a_change_made_in_code_is_reported_as_not_exact(tmp_path: Path) -> None:
    """Code that removes the robot's rate limits (the reproductions do) is not expressible in
    a scenario: run.json says so instead of pretending."""
    exp = build(parse_scenario(tomllib.loads(GOOD), "mine"))
    exp.limits = exp.limits.without_rates()
    exp.run().save(tmp_path / "r")
    meta = json.loads((tmp_path / "r" / "run.json").read_text())
    assert meta["exact"] is False
    assert any("qdot_max" in why for why in meta["not_exact_because"])
    assert "Not an exact re-run" in (tmp_path / "r" / "scenario.toml").read_text()


def test_plot_redraws_a_run_and_a_comparison(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    cmp = tmp_path / "cmp"
    scenario = str(_scenario(tmp_path))
    assert main(["compare", scenario, "--methods", "classical,gpm", "--out", str(cmp), "-q"]) == 0
    assert (cmp / "joints.png").is_file()
    for p in cmp.glob("*.png"):
        p.unlink()
    assert main(["plot", str(cmp), "--format", "pdf"]) == 0
    assert (cmp / "joints.pdf").is_file() and not (cmp / "joints.png").exists()
    assert main(["plot", str(cmp / "gpm")]) == 0
    assert (cmp / "gpm" / "joints.png").is_file() and (cmp / "gpm" / "image.png").is_file()


def test_replay_reruns_a_campaign_sample_like_its_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    camp = tmp_path / "camp"
    args = ["campaign", "afma6-gaze-demo", "--samples", "2", "--methods", "gpm", "--workers", "1"]
    assert main([*args, "--out", str(camp), "-q", "--no-plot"]) == 0
    assert not (camp / "success_rate.png").exists()
    capsys.readouterr()
    assert main(["replay", str(camp), "--sample", "1", "--method", "gpm", "-q", "--no-plot"]) == 0
    out = capsys.readouterr().out
    assert "matches the campaign's stored row" in out
    run = load_run(camp / "replay" / "sample-1-gpm")
    row = next(
        line.split(",")
        for line in (camp / "samples.csv").read_text().splitlines()
        if line.startswith("1,gpm,")
    )
    assert str(run.summary["iterations"]) in row
    sc = load_scenario(run.path / "scenario.toml")
    assert sc.spec.control.method == "gpm"
    if pytest.importorskip("matplotlib"):
        assert main(["plot", str(camp)]) == 0
        assert (camp / "success_rate.png").is_file() and (camp / "iterations.png").is_file()


def test_replay_of_a_directory_that_is_not_a_campaign(tmp_path: Path) -> None:
    assert main(["replay", str(tmp_path), "--sample", "0", "--method", "gpm"]) == 2
