"""Tampered run directories (issue 32): a truncated ``log.npz``, an array cut short, a wrong
joint count or a NaN in the joints is one error naming the file and key (exit 2, one line,
no traceback, on the command line), never an internal error or a silent figure."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from redservo import load_run
from redservo.cli.entry import main
from redservo.errors import ConfigurationError
from tests.test_scenario import GOOD


@pytest.fixture(scope="module")
def saved(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("tamper")
    (root / "my.toml").write_text(GOOD)
    out = root / "run"
    assert main(["run", str(root / "my.toml"), "--out", str(out), "-q", "--no-plot"]) == 0
    return out


def _copy(saved: Path, tmp_path: Path) -> Path:
    run = tmp_path / "run"
    shutil.copytree(saved, run)
    return run


def _edit(run: Path, **changes: np.ndarray) -> None:
    with np.load(run / "log.npz", allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    data.update(changes)
    np.savez_compressed(run / "log.npz", **data)


def _q(run: Path) -> np.ndarray:
    with np.load(run / "log.npz", allow_pickle=False) as npz:
        return np.array(npz["q"])


def test_a_saved_run_loads(saved: Path) -> None:
    assert len(load_run(saved)) == load_run(saved).summary["iterations"]


def test_a_truncated_log_is_one_clear_error(saved: Path, tmp_path: Path) -> None:
    run = _copy(saved, tmp_path)
    data = (run / "log.npz").read_bytes()
    (run / "log.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(ConfigurationError, match=r"log\.npz: damaged or truncated"):
        load_run(run)


@pytest.mark.parametrize(
    ("tamper", "match"),
    [
        (lambda q: q[:5], r"key 'q' has shape \(5, \d+\), expected \d+ rows"),
        (lambda q: q[:, :-1], r"key 'q' has shape .*\(joints\)"),
        (lambda q: np.where(np.arange(q.shape[0])[:, None] == 2, np.nan, q), "'q' holds NaN"),
        (lambda q: q.astype(str), "'q' holds <U"),
    ],
)
def test_a_tampered_array_is_one_error_naming_file_and_key(
    saved: Path, tmp_path: Path, tamper: object, match: str
) -> None:
    run = _copy(saved, tmp_path)
    _edit(run, q=tamper(_q(run)))  # type: ignore[operator]
    with pytest.raises(ConfigurationError, match=match) as caught:
        load_run(run)
    assert str(run / "log.npz") in str(caught.value)


def test_a_log_cut_short_everywhere_disagrees_with_the_summary(saved: Path, tmp_path: Path) -> None:
    run = _copy(saved, tmp_path)
    with np.load(run / "log.npz", allow_pickle=False) as npz:
        data = {
            k: (npz[k][:5] if k not in ("joint_names", "feature_names", "flag_names") else npz[k])
            for k in npz.files
        }
    np.savez_compressed(run / "log.npz", **data)
    with pytest.raises(
        ConfigurationError, match=r"has 5 rows but summary\.json says \d+ iterations"
    ):
        load_run(run)


@pytest.mark.parametrize("command", [["plot"], ["animate"]])
def test_the_cli_refuses_a_tampered_run_in_one_line(
    saved: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], command: list[str]
) -> None:
    run = _copy(saved, tmp_path)
    _edit(run, q=_q(run)[:5])
    capsys.readouterr()
    extra = ["--out", str(tmp_path / "x.gif")] if command == ["animate"] else []
    assert main([*command, str(run), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1
    assert "log.npz" in err and "'q'" in err
