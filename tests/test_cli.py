"""The redservo command line: commands, outputs and exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from redservo.cli import main
from tests.test_scenario import GOOD


@pytest.mark.parametrize("command", ["run", "compare", "list", "reproduce", "campaign", "bench"])
def test_help_documents_every_command(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert "usage: redservo " + command in capsys.readouterr().out


def test_list(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "afma6-gaze-demo" in out and "iterative-smooth" in out and "directional" in out


def test_user_scenario_run_with_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A user writes their own TOML and runs `redservo run my.toml --plot` (issue 4)."""
    pytest.importorskip("matplotlib")
    scenario = tmp_path / "my.toml"
    scenario.write_text(GOOD)
    out = tmp_path / "out"
    assert main(["run", str(scenario), "--plot", "--out", str(out), "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "converged"
    assert summary["scenario"] == "mine" and summary["method"] == "iterative-smooth"
    for name in ("log.npz", "log.csv", "joints.png", "error.png", "image.png"):
        assert (out / name).is_file(), name
    assert "converged" in capsys.readouterr().out


def test_joint_limit_outcome_is_not_an_error(tmp_path: Path) -> None:
    scenario = tmp_path / "edge.toml"
    # Classical from near the limits (see tests/test_simulation.py): hits axis 1.
    text = GOOD.replace(
        "q0 = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0]",
        "q0 = [-0.5967, -0.165, 0.4119, 1.2829, 0.3967, -0.6108]",
    ).replace("translation = [0.1, 0.05, 0.8]", "translation = [-0.368, 0.017, 0.876]")
    scenario.write_text(text.replace("dt = 0.04", "dt = 0.08"))
    out = tmp_path / "o"
    # The paper's law exactly (no shield) crosses; with the default shield it would not.
    args = ["run", str(scenario), "--method", "classical", "--out", str(out), "-q"]
    assert main([*args, "--set", "control.shield=false"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "joint_limit"
    assert summary["success"] is False


def test_set_and_compare(tmp_path: Path) -> None:
    scenario = tmp_path / "my.toml"
    scenario.write_text(GOOD)
    out = tmp_path / "cmp"
    code = main(
        [
            "compare",
            str(scenario),
            "--methods",
            "classical,iterative",
            "--set",
            "control.lam=0.8",
            "--out",
            str(out),
            "-q",
        ]
    )
    assert code == 0
    table = json.loads((out / "compare.json").read_text())
    assert set(table["methods"]) == {"classical", "iterative"}
    assert "| classical |" in (out / "compare.md").read_text()


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "no-such-scenario"],
        ["run", "afma6-gaze-demo", "--method", "magic"],
        ["run", "afma6-gaze-demo", "--set", "robot.q0=[9,0,0,0,0,0]"],
        ["run", "afma6-gaze-demo", "--set", "control.lam"],
        ["compare", "afma6-gaze-demo", "--methods", "classical,nope"],
    ],
)
def test_bad_input_exits_2_with_a_message(
    argv: list[str], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    assert (
        main([*argv, "-q"] if argv[0] != "compare" else [*argv, "--out", str(tmp_path), "-q"]) == 2
    )
    err = capsys.readouterr().err
    assert err.startswith("redservo: error: ") and "Traceback" not in err


# -- issue 14: the commands on saved results, and the flags every command shares ----------


@pytest.mark.parametrize("command", ["plot", "replay", "view", "animate"])
def test_help_of_the_result_commands(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert "usage: redservo " + command in capsys.readouterr().out


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    from redservo import __version__

    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"redservo {__version__}"


def test_list_names_everything_and_q_gives_names_only(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for title in ("Scenarios", "Campaigns", "Robots", "Methods", "Experiments"):
        assert f"\n{title} (" in f"\n{out}", title
    assert "panda" in out and "cm01-gaze" in out and "(7 joints)" in out
    assert main(["list", "-q"]) == 0
    names = capsys.readouterr().out.split()
    assert "afma6-gaze-demo" in names and "classical" in names and "humanoid9" in names
    assert all(" " not in n for n in names)


def test_run_plots_by_default_in_the_formats_asked(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    scenario = tmp_path / "my.toml"
    scenario.write_text(GOOD.replace("max_iterations = 300", "max_iterations = 30"))
    out = tmp_path / "o"
    assert main(["run", str(scenario), "--out", str(out), "-q", "--format", "svg,pdf"]) == 0
    assert (out / "joints.svg").is_file() and (out / "joints.pdf").is_file()
    assert not (out / "joints.png").exists()
    assert main(["run", str(scenario), "--out", str(tmp_path / "n"), "-q", "--no-plot"]) == 0
    assert not list((tmp_path / "n").glob("*.png"))
    assert main(["run", str(scenario), "--out", str(out), "--format", "jpg"]) == 2


def test_reproduce_summary_names_the_claims_not_reproduced() -> None:
    from redservo.cli_tools import reproduce_lines

    report = {
        "experiments": [
            {"id": "a", "claims": [{"claim": "x converges", "reproduced": True}]},
            {"id": "b", "claims": [{"claim": "y   avoids\nthe limit", "reproduced": False}]},
        ]
    }
    lines = reproduce_lines(report, Path("out"))
    assert lines[0] == "reproduced 1/2 claims"
    assert "  - [b] y avoids the limit" in lines
    assert lines[-1].startswith("details, evidence and figures: out/report.md")


def test_campaign_set_overrides_the_base_scenario(tmp_path: Path) -> None:
    out = tmp_path / "c"
    args = ["campaign", "afma6-gaze-demo", "--samples", "1", "--methods", "gpm", "--workers", "1"]
    args += ["--set", "simulation.max_iterations=5", "--out", str(out), "-q", "--no-plot"]
    assert main(args) == 0
    row = (out / "samples.csv").read_text().splitlines()[1]
    assert ",max_iterations,False,5," in row
