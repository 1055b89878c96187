"""The success verdict in words (issue 32): one function says it, every place that shows an
outcome shows it, and a run the shield had to rescue never reads just "converged"."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

import redservo
from redservo.cli.common import summary_line
from redservo.records import failure_reasons, outcome_text, verdict
from redservo.runs.tables import summary_table

ROOT = Path(__file__).resolve().parents[1]
SRC = Path(redservo.__file__).resolve().parent


def _summary(**changes: Any) -> dict[str, Any]:
    """A summary.json dict of a safe converged run, with ``changes``."""
    s: dict[str, Any] = {
        "outcome": "converged",
        "success": True,
        "iterations": 120,
        "final_error_norm": 9e-4,
        "limit_hit": None,
        "min_margin": 0.05,
        "min_margin_required": 0.01,
        "max_joint_speed": [0.1, 0.2],
        "peak_velocity_ratio": 0.4,
        "velocity_violations": 0,
        "acceleration_violations": 0,
        "shield_activations": 0,
        "max_camera_speed": {"translation": 0.1, "rotation": 0.2},
        "discontinuity": 0.01,
        "flags": {},
    }
    s.update(changes)
    return s


RESCUED = _summary(success=False, shield_activations=12, min_margin=0.004)


def test_a_success_says_success() -> None:
    assert verdict(_summary()) == "success"
    assert outcome_text(_summary()) == "converged — success"
    assert failure_reasons(_summary()) == []


def test_a_run_the_shield_rescued_says_why_it_is_no_success() -> None:
    assert outcome_text(RESCUED) == (
        "converged — no success: the shield acted at 12 step(s); "
        "min margin 0.0040 below the success margin 0.0100"
    )


@pytest.mark.parametrize(
    ("changes", "said"),
    [
        (
            {"outcome": "joint_limit", "limit_hit": {"axis": 1, "iteration": 40}},
            "joint 1 'elbow' hit its limit at iteration 40",
        ),
        ({"outcome": "max_iterations"}, "iteration cap reached (120 iterations)"),
        ({"outcome": "target_lost"}, "target lost (left the image)"),
        ({"outcome": "occluded"}, "target occluded"),
        ({"outcome": "feature_lost"}, "a feature was lost"),
        ({"outcome": "interrupted"}, "ended interrupted"),
        ({"velocity_violations": 3}, "velocity limit exceeded at 3 step(s)"),
        ({"acceleration_violations": 2}, "acceleration limit exceeded at 2 step(s)"),
        ({"min_margin": 0.009}, "min margin 0.0090 below the success margin 0.0100"),
        ({}, "not safe (the summary does not say why)"),
    ],
)
def test_each_reason_is_named(changes: dict[str, Any], said: str) -> None:
    text = verdict(_summary(success=False, **changes), ["shoulder", "elbow"])
    assert text.startswith("no success: ") and said in text, text


def test_a_summary_without_success_is_not_guessed() -> None:
    old = _summary()
    del old["success"]
    assert verdict(old) == "success not recorded"


def test_console_line_and_compare_table_show_the_verdict() -> None:
    line = summary_line("cm01-gaze [gpm]", RESCUED)
    assert line.startswith("cm01-gaze [gpm]: converged — no success: the shield acted at 12"), line
    table = summary_table({"gpm": RESCUED, "qp": _summary()})
    assert "| gpm | converged — no success: the shield acted at 12 step(s)" in table
    assert "| qp | converged — success |" in table


def test_the_viewer_panel_and_animate_title_call_the_verdict() -> None:
    """Both are drawn from the run's summary by outcome_text (their rendering is tested in
    test_viewer.py; here: they never show the bare outcome)."""
    for path in (SRC / "viewer" / "server.py", SRC / "viewer" / "animate.py"):
        text = path.read_text()
        assert "outcome_text(" in text and ".outcome}" not in text, path


# An f-string field that shows a run's outcome: {s.outcome}, {summary['outcome']}, ...
_SHOWS_OUTCOME = re.compile(r"\{[^{}\n]*\boutcome\b[^{}\n]*\}")
_NOT_A_RUN_OUTCOME = {
    # why a drawn start is invalid ("target_lost at the start"), not how a run ended
    ("campaign/sampling.py", "{res.outcome}"),
    ("campaign/start.py", "{outcome}"),
    # dict comprehensions counting outcomes, not showing one
    ("campaign/stats.py", "outcomes.count(o)"),
    ("campaign/table.py", "enumerate(self.outcomes)"),
}


def _python_files() -> list[Path]:
    files = list(SRC.rglob("*.py"))
    files.remove(SRC / "records" / "verdict.py")  # the one function that words it
    return files + sorted((ROOT / "examples").glob("*.py"))


def test_no_place_shows_an_outcome_without_the_verdict() -> None:
    """Every f-string field naming an outcome goes through outcome_text/verdict."""
    bad = []
    for path in _python_files():
        rel = path.relative_to(SRC).as_posix() if path.is_relative_to(SRC) else path.name
        for field in _SHOWS_OUTCOME.findall(path.read_text()):
            if "outcome_text(" in field or "verdict(" in field:
                continue
            if re.search(r"[\"']outcome[\"']\s*:", field):
                continue  # a dict literal recording the outcome as data (a check's evidence)
            if any(rel == where and what in field for where, what in _NOT_A_RUN_OUTCOME):
                continue
            bad.append(f"{rel}: {field}")
    assert not bad, "outcome shown without its verdict: " + "; ".join(bad)


def test_the_examples_print_the_verdict(capsys: pytest.CaptureFixture[str]) -> None:
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "compare_methods", ROOT / "examples" / "compare_methods.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--quick"]) == 0
    out = capsys.readouterr().out
    assert "max_iterations — no success: iteration cap reached (30 iterations)" in out, out


@pytest.fixture(scope="module")
def capped_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 20-iteration run, saved: no success (iteration cap)."""
    out = tmp_path_factory.mktemp("verdict") / "run"
    redservo.run("afma6-gaze-demo", max_iterations=20, out=out)
    return out


CAPPED = "max_iterations — no success: iteration cap reached (20 iterations) before convergence"


def test_animate_title_shows_the_verdict(
    capped_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("matplotlib")
    pytest.importorskip("PIL")
    from matplotlib.figure import Figure

    from redservo.cli.entry import main

    titles: list[str] = []
    real = Figure.suptitle

    def spy(self: Figure, t: str, **kwargs: Any) -> Any:
        titles.append(t)
        return real(self, t, **kwargs)

    monkeypatch.setattr(Figure, "suptitle", spy)
    assert (
        main(["animate", str(capped_run), "--out", str(tmp_path / "a.gif"), "--frames", "2"]) == 0
    )
    assert len(titles) == 1 and CAPPED in titles[0].replace("\n", " "), titles


def test_the_viewer_panel_shows_the_verdict(capped_run: Path) -> None:
    from types import SimpleNamespace
    from unittest.mock import MagicMock

    from redservo.viewer.playback import Playback
    from redservo.viewer.server import _build_gui

    pb = Playback(redservo.load_run(capped_run))
    server = MagicMock()
    stopped = MagicMock()
    stopped.wait.return_value = True  # the player thread ends at once
    session = SimpleNamespace(
        server=server, playback=pb, handles={}, frames=[0, len(pb) - 1], stopped=stopped
    )
    _build_gui(session)  # type: ignore[arg-type]
    panel = server.gui.add_markdown.call_args_list[0].args[0]
    assert CAPPED in panel, panel
