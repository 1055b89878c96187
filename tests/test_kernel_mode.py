"""Compiled or plain kernels for a command (redservo.bench.kernel_mode): a cold cache runs the
short commands uncompiled, with the same numbers, and says so once."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from redservo.bench import kernel_mode as kernel_mode
from redservo.cli.entry import main
from redservo.errors import ConfigurationError

pytest.importorskip("numba")

SRC = Path(__file__).resolve().parents[1] / "src"


def _env(cache: Path, **extra: str) -> dict[str, str]:
    env = {
        k: v for k, v in os.environ.items() if k not in ("REDSERVO_NO_NUMBA", "REDSERVO_KERNELS")
    }
    env.update(NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(SRC), **extra)
    return env


def _choose(cache: Path, command: str, **extra: str) -> tuple[list[object], str]:
    """``choose_for_command(command)`` in a fresh process (no kernel imported yet), and the
    REDSERVO_NO_NUMBA it leaves."""
    code = (
        "import json, os; from redservo.bench.kernel_mode import choose_for_command as c; "
        f"print(json.dumps([list(c({command!r})), os.environ.get('REDSERVO_NO_NUMBA', '')]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        env=_env(cache, **extra),
        capture_output=True,
        text=True,
        check=True,
    )
    choice, flag = json.loads(out.stdout)
    return choice, flag


def test_a_cold_cache_runs_the_short_commands_uncompiled(tmp_path: Path) -> None:
    for command in sorted(kernel_mode.AUTO_COMMANDS):
        assert _choose(tmp_path, command) == (["python", True], "1")
    for command in ("campaign", "bench", "servo"):  # long or real-time: compiled
        assert _choose(tmp_path, command) == (["compiled", False], "")


def test_a_replay_runs_compiled_as_its_campaign_did(tmp_path: Path) -> None:
    """A campaign runs compiled; its replay on a cold cache ran the plain functions, whose
    rounding differs by a few ULP, which a long predictive run amplified into another row
    (mc05-joint-limits sample 22: converged in the campaign, at the cap in the replay)."""
    assert "replay" not in kernel_mode.AUTO_COMMANDS
    assert _choose(tmp_path, "replay") == (["compiled", False], "")


def test_the_environment_variable_forces_either_way(tmp_path: Path) -> None:
    assert _choose(tmp_path, "run", REDSERVO_KERNELS="compiled") == (["compiled", False], "")
    assert _choose(tmp_path, "campaign", REDSERVO_KERNELS="python") == (["python", False], "1")
    assert _choose(tmp_path, "run", REDSERVO_NO_NUMBA="1") == (["python", False], "1")


def _py(cache: Path, code: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", code], env=_env(cache), capture_output=True, text=True, check=True
    )
    return out.stdout.strip()


def test_a_warm_up_marker_makes_them_compiled(tmp_path: Path) -> None:
    """numba reads NUMBA_CACHE_DIR once, at import: each step in a fresh process."""
    ask = "from redservo.bench.kernel_mode import is_warm; print(is_warm())"
    assert _py(tmp_path, ask) == "False"
    marker = Path(
        _py(tmp_path, "from redservo.bench.kernel_mode import mark_warm; print(mark_warm())")
    )
    assert marker.is_file() and tmp_path in marker.parents
    assert _py(tmp_path, ask) == "True"
    assert _choose(tmp_path, "run") == (["compiled", False], "")
    # another numba (or a kernel edit, or another Python) is another stamp: cold again
    assert kernel_mode._stamp("0.0") != kernel_mode._stamp("0.1")


def test_a_bad_mode_is_one_error_naming_the_variable(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("REDSERVO_KERNELS", "fast")
    with pytest.raises(ConfigurationError, match="REDSERVO_KERNELS must be one of auto, compiled"):
        kernel_mode.requested_mode()
    assert main(["run", "panda-4points", "--no-plot", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "REDSERVO_KERNELS" in err[0] and "'fast'" in err[0]


def test_the_uncompiled_first_run_gives_the_compiled_run_bit_for_bit(tmp_path: Path) -> None:
    """A cold `redservo run panda-4points` in a fresh process: one notice line, run.json says
    "python", and its log is the compiled run's (this process runs compiled) byte for byte."""
    cold = tmp_path / "cold"
    out = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from redservo.cli.entry import main; sys.exit(main())",
            "run",
            "panda-4points",
            "--no-plot",
            "--out",
            str(cold),
        ],
        env=_env(tmp_path / "cache"),
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stderr.count("not compiled on this machine yet") == 1
    assert "compiling" not in out.stderr
    assert json.loads((cold / "run.json").read_text())["kernels"] == "python"
    warm = tmp_path / "warm"
    assert main(["run", "panda-4points", "--no-plot", "-q", "--out", str(warm)]) == 0
    assert json.loads((warm / "run.json").read_text())["kernels"].startswith("numba ")
    a, b = np.load(cold / "log.npz"), np.load(warm / "log.npz")
    assert a.files == b.files
    for key in a.files:
        assert a[key].tobytes() == b[key].tobytes(), key


def test_the_command_line_starts_without_importing_numba(tmp_path: Path) -> None:
    """The choice is made before any kernel is imported: importing the command line (and
    `import redservo`) must not import numba or a kernel module that would decide it."""
    code = (
        "import sys; import redservo.cli.entry; "
        "print('numba' in sys.modules, 'redservo.kernels._jit' in sys.modules)"
    )
    assert _py(tmp_path, code) == "False False"
