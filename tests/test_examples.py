"""Every script of examples/ runs (issue 22, part 4), in its quick form (few iterations).

The scripts run in this process (runpy, as ``__main__`` would, with ``--quick``), so that the
test pays no interpreter start-up and no kernel load per script."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
QUICK = ["run_scenario.py", "compare_methods.py", "controller_loop.py", "small_campaign.py"]


ELSEWHERE = {
    "demo.py": "make demo runs it",
    "real_robot.py": "tests/test_servo_loop.py runs it",
    "calibration_demo.py": "writes calibration images for redservo calibrate (docs/vision.md)",
    "custom_law_damped.py": "tests/test_law_declaration.py runs it (a new process: it adds a law)",
    "scara_robot.py": "tests/test_robot_kinds.py runs it (a new process: it adds a robot kind)",
    "custom_feature_segment.py": "tests/test_feature_example.py runs it (it adds a feature kind)",
}
"""Examples not run here, and why."""


def test_every_example_is_run_here_or_said_where() -> None:
    shipped = {p.name for p in EXAMPLES.glob("*.py")}
    assert shipped - set(ELSEWHERE) == set(QUICK)


@pytest.mark.parametrize("script", QUICK)
def test_the_example_runs(
    script: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "out"
    argv = [str(EXAMPLES / script), "--quick"]
    if script != "controller_loop.py":
        argv += ["--out", str(out)]
    monkeypatch.setattr(sys, "argv", argv)
    with pytest.raises(SystemExit) as info:
        runpy.run_path(argv[0], run_name="__main__")
    assert info.value.code == 0
    text = capsys.readouterr().out
    assert text.strip(), "an example says what it did"
    if script != "controller_loop.py":
        assert out.is_dir() and any(out.iterdir())
