"""The redservo command line: commands, outputs and exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from redservo.cli.entry import main
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


def test_one_joint_numbering_everywhere(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Joints are numbered from 0 on the console, in summary.json, in compare.md and in the
    log columns (README, Conventions)."""
    scenario = tmp_path / "edge.toml"
    text = GOOD.replace(
        "q0 = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0]",
        "q0 = [-0.5967, -0.165, 0.4119, 1.2829, 0.3967, -0.6108]",
    ).replace("translation = [0.1, 0.05, 0.8]", "translation = [-0.368, 0.017, 0.876]")
    scenario.write_text(text.replace("dt = 0.04", "dt = 0.08"))
    out = tmp_path / "o"
    args = [
        "compare",
        str(scenario),
        "--methods",
        "classical",
        "--out",
        str(out),
        "-q",
        "--no-plot",
    ]
    assert main([*args, "--set", "control.shield=false"]) == 0
    hit = json.loads((out / "classical" / "summary.json").read_text())["limit_hit"]
    from redservo.robots import Afma6

    name = Afma6().joint_names[hit["axis"]]
    console = capsys.readouterr().out
    said = f"no success: joint {hit['axis']} {name!r} hit its limit at iteration {hit['iteration']}"
    assert said in console
    table = (out / "compare.md").read_text()
    assert f"no success: joint {hit['axis']} hit its limit at iteration {hit['iteration']}" in table
    header = (out / "classical" / "log.csv").read_text().split("\n", 1)[0].split(",")
    assert "q[0]" in header and "q[6]" not in header  # 6 joints: q[0] ... q[5]


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


# --------------------------------------------------------------------------- failure modes


def _one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if not line.startswith("redservo campaign: ")]
    assert len(lines) == 1, err
    assert lines[0].startswith("redservo: error: ") and "Traceback" not in err, err
    return lines[0]


BAD_CAMPAIGN = Path(__file__).parent / "data" / "bad_scenarios" / "binary_garbage.toml"


@pytest.mark.parametrize(
    ("argv", "expect"),
    [
        (["run", "afma6-gaze-demo", "--set", "control.dt=-1"], "key 'control.dt'"),
        (["run", "afma6-gaze-demo", "--set", "control.lam=inf"], "key 'control.lam'"),
        (["compare", "afma6-gaze-demo", "--methods", " , "], "give at least one method"),
        (["compare", str(BAD_CAMPAIGN), "--methods", "classical"], "not a text file"),
        (["campaign", str(BAD_CAMPAIGN)], "not a text file"),
        (["campaign", "no-such-campaign"], "shipped campaigns"),
        (["campaign", "afma6-gaze-demo", "--samples", "0"], "--samples: must be in [1, 1000000]"),
        (["campaign", "afma6-gaze-demo", "--samples", "1e12"], "expected an integer"),
        (["campaign", "afma6-gaze-demo", "--workers", "0"], "--workers"),
        (["campaign", "afma6-gaze-demo", "--seed", "-3"], "--seed"),
        (["campaign", "afma6-gaze-demo", "--methods", "nope"], "unknown method 'nope'"),
        (["reproduce", "--only", "nope"], "unknown experiment 'nope'"),
        (["bench", "--repeat", "0"], "--repeat: must be in [1, 1000000]"),
        (["bench", "--repeat", "many"], "expected an integer"),
        (["frobnicate"], "invalid choice"),
        (["run"], "the following arguments are required"),
    ],
)
def test_every_command_fails_in_one_line_with_exit_2(
    argv: list[str], expect: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    extra = (
        ["--out", str(tmp_path / "o")] if argv[0] in ("compare", "campaign", "reproduce") else []
    )
    assert main([*argv, *extra]) == 2
    assert expect in _one_error_line(capsys)


def test_a_bad_campaign_file_names_file_and_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "c.toml"
    path.write_text('scenario = "afma6-gaze-demo"\nsamples = 5\n[start]\np_bnd = 0.5\n')
    assert main(["campaign", str(path), "--out", str(tmp_path / "o"), "-q"]) == 2
    line = _one_error_line(capsys)
    assert (
        line.startswith(f"redservo: error: {path}: key 'start.p_bnd'")
        and "did you mean 'p_band'" in line
    )
    path.write_text('scenario = "afma6-gaze-demo"\n[overrides]\ncontrol = { lam = 1e300 }\n')
    assert main(["campaign", str(path), "--out", str(tmp_path / "o"), "-q"]) == 2
    assert f"{path}: key 'overrides.control.lam': must be <= 1000" in _one_error_line(capsys)


def test_an_unwritable_output_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    assert main(["run", "afma6-gaze-demo", "--out", str(blocker / "o"), "-q"]) == 2
    assert str(blocker) in _one_error_line(capsys)


def test_a_missing_extra_is_one_line_with_pip_install(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Without matplotlib: the reproduction (figures are its result) stops in one line before
    running; a run keeps its numbers and says in one line that the figures were skipped."""
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # as if it were not installed
    out = tmp_path / "repro"
    assert main(["reproduce", "--fast", "--out", str(out), "-q"]) == 2
    assert "pip install 'redservo[plot]'" in _one_error_line(capsys)
    assert not out.exists()  # it failed before running anything
    assert main(["run", "afma6-gaze-demo", "--out", str(tmp_path / "run"), "-q"]) == 0
    assert capsys.readouterr().err == "figures skipped: pip install 'redservo[plot]'\n"
    assert (tmp_path / "run" / "summary.json").is_file()


def test_debug_shows_the_traceback_and_a_bug_exits_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    argv = ["run", "afma6-gaze-demo", "--set", "control.dt=0", "--out", str(tmp_path), "-q"]
    assert main([*argv, "--debug"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" in err and err.rstrip().splitlines()[-1].startswith("redservo: error: ")
    assert main(["--debug", *argv]) == 2  # before or after the command
    assert "Traceback" in capsys.readouterr().err

    import redservo.experiment.build

    def broken(*_a: object, **_k: object) -> None:
        raise RuntimeError("a bug")

    monkeypatch.setattr(redservo.experiment.build, "build", broken)
    assert main(["run", "afma6-gaze-demo", "--out", str(tmp_path), "-q"]) == 1
    line = _one_error_line(capsys)
    assert "internal error: RuntimeError: a bug" in line and "--debug" in line


def test_run_prints_one_warning_per_flag(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from redservo.simulation import flag_warnings

    out = tmp_path / "o"
    argv = ["run", "panda-4points", "--method", "classical", "--out", str(out), "-q", "--no-plot"]
    assert main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    want = flag_warnings(summary)
    assert want, "the classical law needs the shield on this scenario"
    err = capsys.readouterr().err.splitlines()
    hints = [line for line in err if line.startswith("hint: classical needed the position shield")]
    assert len(hints) == 1, err  # the one line that suggests other laws (tests/test_advice.py)
    assert [line for line in err if line not in hints] == [f"warning: {line}" for line in want]


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
    from redservo.cli.tools import reproduce_lines

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


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["run", "afma6-gaze-demo", "--method", ""], "--method"),
        (["run", "afma6-gaze-demo", "--method", "  "], "--method"),
        (["compare", "afma6-gaze-demo", "--methods", ""], "--methods"),
        (["compare", "afma6-gaze-demo", "--methods", "classical,,gpm"], "--methods"),
        (["compare", "afma6-gaze-demo", "--methods", "classical,"], "--methods"),
        (["campaign", "afma6-gaze-demo", "--methods", ""], "--methods"),
        (["campaign", "afma6-gaze-demo", "--methods", "gpm, ,wln"], "--methods"),
        (["bench", "--methods", ""], "--methods"),
        (["replay", "no-such-dir", "--sample", "0", "--method", ""], "--method"),
    ],
)
def test_an_empty_method_name_is_an_error_naming_the_option_and_the_methods(
    argv: list[str], option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--method ''` used to run the scenario's own method (and `--methods a,,b` dropped the
    empty entry): now one line, exit code 2, naming the option and the methods allowed."""
    from redservo import METHODS

    assert main([*argv, "--out", str(tmp_path / "o"), "-q"] if argv[0] != "bench" else argv) == 2
    line = _one_error_line(capsys)
    assert f"argument {option}:" in line and "method name" in line
    assert all(m in line for m in METHODS)
    assert not (tmp_path / "o").exists()  # nothing ran


def test_a_closed_pipe_ends_quietly() -> None:
    """`redservo list | head -1`: the reader has gone; no error line, no traceback."""
    import os
    import subprocess
    import sys

    r, w = os.pipe()
    os.close(r)  # no reader at all, before the command writes anything
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "redservo.cli.entry", "list"],
            stdout=w,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
        )
    finally:
        os.close(w)
    assert proc.returncode == 141, proc.stderr
    assert proc.stderr == ""


def test_campaign_says_which_files_it_wrote(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """With --no-plot no figure is written, and the last line must not claim any."""
    common = ["campaign", "afma6-gaze-demo", "--samples", "2", "--methods", "gpm", "--seed", "0"]
    assert main([*common, "--no-plot", "--out", str(tmp_path / "a"), "-q"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.endswith("campaign.md, campaign.json"), last
    assert not list((tmp_path / "a").glob("*.png"))
    assert main([*common, "--out", str(tmp_path / "b"), "-q"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    n = len(list((tmp_path / "b").glob("*.png")))
    assert n > 0 and last.endswith(f"campaign.json and {n} figure(s)"), last


# --------------------------------------------------------------------------- one command line


@pytest.mark.parametrize(
    "argv", [["run", "afma6-gaze-demo", "--bogus"], ["frobnicate"], ["plot", "--method", "gpm"]]
)
def test_usage_errors_have_one_prefix(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    line = _one_error_line(capsys)
    assert line.count("redservo") <= 2 and "error: redservo" not in line, line
    assert "--help')" in line


def test_plot_help_names_only_its_options(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["plot", "--help"])
    text = capsys.readouterr().out
    assert "--out" in text and "--method" not in text


def test_plot_refuses_a_folder_that_is_not_a_result(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A folder of unrelated runs is no comparison: nothing is written into it."""
    for m in ("gpm", "classical"):
        assert (
            main(
                [
                    "run",
                    "afma6-gaze-demo",
                    "--method",
                    m,
                    "--set",
                    "simulation.max_iterations=5",
                    "--out",
                    str(tmp_path / m),
                    "-q",
                    "--no-plot",
                ]
            )
            == 0
        )
    capsys.readouterr()
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(["plot", str(tmp_path)]) == 2
    line = _one_error_line(capsys)
    assert "not a run" in line and "runs inside: classical, gpm" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    if pytest.importorskip("matplotlib"):
        assert (
            main(
                ["plot", str(tmp_path / "gpm"), "--out", str(tmp_path / "figs"), "--format", "svg"]
            )
            == 0
        )
        assert (tmp_path / "figs" / "joints.svg").is_file()
        assert not (tmp_path / "gpm" / "joints.png").exists()


def test_replay_refuses_a_sample_outside_the_campaign_unless_new(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    camp = tmp_path / "camp"
    args = [
        "campaign",
        "afma6-gaze-demo",
        "--samples",
        "2",
        "--methods",
        "gpm",
        "--workers",
        "1",
        "--set",
        "simulation.max_iterations=5",
    ]
    assert main([*args, "--out", str(camp), "-q", "--no-plot"]) == 0
    capsys.readouterr()
    replay = ["replay", str(camp), "--sample", "9", "--method", "gpm", "-q", "--no-plot"]
    assert main(replay) == 2
    line = _one_error_line(capsys)
    assert "sample 9 is not in the campaign (samples 0 to 1)" in line and "--new" in line
    assert not (camp / "replay").exists()
    assert main([*replay, "--new"]) == 0
    assert "ran it as a new sample" in capsys.readouterr().err
    assert (camp / "replay" / "sample-9-gpm" / "summary.json").is_file()


def test_list_shows_the_shipped_urdf_robots(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    section = out.split("URDF robots", 1)[1].split("\n\n", 1)[0]
    assert "panda" in section and "ur5e" in section and "panda-urdf-4points" in section
    assert main(["list", "-q"]) == 0
    names = capsys.readouterr().out.split()
    assert "ur5e" in names


def test_a_paper_scenario_changed_by_the_shield_says_how_to_run_the_paper_law() -> None:
    from types import SimpleNamespace

    from redservo.cli.commands import paper_note
    from redservo.scenario import load_scenario

    sc = load_scenario("cm01-humanoid-tracking")
    note = paper_note(sc, SimpleNamespace(shield_activations=250))
    assert note is not None and "\n" not in note
    assert "250 step(s)" in note and "redservo reproduce --only cm01-humanoid-tracking" in note
    assert paper_note(sc, SimpleNamespace(shield_activations=0)) is None
    assert (
        paper_note(load_scenario("afma6-gaze-demo"), SimpleNamespace(shield_activations=3)) is None
    )


def test_every_command_that_writes_takes_out(capsys: pytest.CaptureFixture[str]) -> None:
    """Commands that write files name where with --out (view and warmup write none, list
    prints)."""
    import argparse

    from redservo.cli.parser import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    silent = {"list", "view", "warmup"}
    for name, parser in sub.choices.items():
        flags = {s for a in parser._actions for s in a.option_strings}
        assert ("--out" in flags) != (name in silent), name


# -- issue 33: Ctrl-C in a campaign says how to resume; the rerun says what it reused -------


def test_an_interrupted_campaign_says_rerunning_resumes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import redservo.campaign

    def interrupted(*_args: object, **_kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(redservo.campaign, "run_campaign", interrupted)
    out = tmp_path / "c"
    argv = ["campaign", "afma6-gaze-demo", "--samples", "2", "--out", str(out), "-q"]
    assert main(argv) == 130
    assert capsys.readouterr().err == (
        f"redservo: interrupted; the runs finished so far are stored in {out / 'samples.csv'}: "
        "rerun the same command to resume (it reuses them and computes only the missing runs)\n"
    )


def test_a_resumed_campaign_says_how_many_runs_it_reused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "c"
    common = ["campaign", "afma6-gaze-demo", "--methods", "gpm", "--out", str(out), "-q"]
    assert main([*common, "--samples", "1", "--no-plot"]) == 0
    assert "reused" not in capsys.readouterr().out  # nothing stored before
    assert main([*common, "--samples", "3", "--no-plot"]) == 0
    said = f"reused 1 stored run(s) of {out / 'samples.csv'}, computed 2"
    assert said in capsys.readouterr().out.splitlines()


@pytest.mark.parametrize(
    "argv",
    [
        ["compare", "afma6-gaze-demo", "--methods", "gpm,wlnn"],
        ["campaign", "afma6-gaze-demo", "--methods", "wlnn", "--samples", "1"],
        ["run", "afma6-gaze-demo", "--method", "wlnn"],
    ],
)
def test_an_unknown_method_gets_a_did_you_mean(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([*argv, "--out", str(tmp_path / "o"), "-q", "--no-plot"]) == 2
    line = _one_error_line(capsys)
    assert "unknown method 'wlnn'" in line and line.endswith("(did you mean 'wln'?)"), line


def test_an_unknown_scenario_name_gets_a_did_you_mean(capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("cm01-gaz", "shipped:cm01-gaz"):
        assert main(["run", name, "-q", "--no-plot"]) == 2
        line = _one_error_line(capsys)
        assert f"unknown scenario {name!r}" in line, line
        assert line.endswith("(did you mean 'cm01-gaze'?)"), line


def test_python_dash_m_redservo_is_the_command_line() -> None:
    """`python -m redservo --version`: the same program as the `redservo` script."""
    import subprocess
    import sys

    from redservo import __version__

    proc = subprocess.run(
        [sys.executable, "-m", "redservo", "--version"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"redservo {__version__}"
