"""Campaign files cannot be tampered silently (:mod:`redservo.campaign.storage`): a flipped
``success``, foreign rows (sample 99999, a method named ``'; rm -rf /``) and an edited
``definition.json`` were kept on resume, exit 0, and copied into ``samples.parquet``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from redservo.campaign import run_campaign
from redservo.cli.entry import main
from redservo.errors import ConfigurationError
from tests.test_campaign import quick


def _first(out: Path) -> tuple[str, list[str]]:
    header, *rows = (out / "samples.csv").read_text().splitlines(keepends=True)
    return header, rows


def _edit_rows(out: Path, edit: callable) -> None:  # type: ignore[valid-type]
    header, rows = _first(out)
    (out / "samples.csv").write_text(header + "".join(edit(rows)))


def _campaign(tmp_path: Path) -> Path:
    out = tmp_path / "c"
    run_campaign(quick(), samples=2, seed=0, workers=1, out=out, progress=False)
    return out


def _flip(row: str) -> str:
    return (
        row.replace(",True,", ",False,", 1)
        if ",True," in row
        else row.replace(",False,", ",True,", 1)
    )


_EDITS = [
    lambda rows: [_flip(rows[0]), *rows[1:]],
    lambda rows: [*rows, rows[0].replace("0,", "99999,", 1)],
    lambda rows: [*rows, rows[0].replace(rows[0].split(",")[1], "'; rm -rf /", 1)],
]


@pytest.mark.parametrize(
    "edit", _EDITS, ids=["flipped-success", "foreign-sample", "foreign-method"]
)
def test_a_tampered_row_is_refused_then_repaired_and_never_reaches_the_tables(
    tmp_path: Path, edit: object
) -> None:
    out = _campaign(tmp_path)
    _edit_rows(out, edit)
    with pytest.raises(ConfigurationError, match=r"fail their check .*--repair"):
        run_campaign(quick(), samples=2, seed=0, workers=1, out=out, progress=False)
    res = run_campaign(quick(), samples=2, seed=0, workers=1, out=out, progress=False, repair=True)
    assert {(r["sample"], r["method"]) for r in res.rows} == {
        (s, m) for s in range(2) for m in quick().methods
    }
    assert res.computed == (1 if edit is _EDITS[0] else 0)  # a flipped row is run again
    text = (out / "samples.csv").read_text()
    assert "99999" not in text and "rm -rf" not in text
    pq = pytest.importorskip("pyarrow.parquet")
    table = pq.read_table(out / "samples.parquet").to_pylist()
    assert {r["sample"] for r in table} == {0, 1} and "'; rm -rf /" not in {
        r["method"] for r in table
    }


def test_an_edited_definition_json_is_refused(tmp_path: Path) -> None:
    out = _campaign(tmp_path)
    meta = json.loads((out / "definition.json").read_text())
    meta["scenario"].setdefault("simulation", {})["max_iterations"] = 5
    (out / "definition.json").write_text(json.dumps(meta, indent=2))
    with pytest.raises(ConfigurationError, match=r"definition\.json was edited"):
        run_campaign(quick(), samples=2, seed=0, workers=1, out=out, progress=False)
    res = run_campaign(quick(), samples=2, seed=0, workers=1, out=out, progress=False, repair=True)
    assert res.computed == 0  # the rows were intact: kept
    fixed = json.loads((out / "definition.json").read_text())
    assert fixed["scenario"] == json.loads(json.dumps(quick().scenario.data, default=str))


def test_the_command_line_says_it_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    campaign = tmp_path / "quick.toml"
    campaign.write_text(
        'scenario = "afma6-gaze-demo"\nmethods = ["gpm"]\nsamples = 1\n'
        "[target]\ntranslation = [[-0.01, 0.01], [-0.01, 0.01], [-0.01, 0.01]]\n"
    )
    args = [
        "campaign",
        str(campaign),
        "--out",
        str(tmp_path / "c"),
        "--workers",
        "1",
        "-q",
        "--no-plot",
    ]
    assert main(args) == 0
    _edit_rows(tmp_path / "c", lambda rows: [_flip(rows[0]), *rows[1:]])
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "fail their check" in err[0] and "Traceback" not in err[0]


def test_replay_refuses_an_edited_definition_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = _campaign(tmp_path)
    meta = json.loads((out / "definition.json").read_text())
    meta["scenario"].setdefault("simulation", {})["max_iterations"] = 5
    (out / "definition.json").write_text(json.dumps(meta, indent=2))
    capsys.readouterr()
    code = main(["replay", str(out), "--sample", "0", "--method", "gpm", "-q", "--no-plot"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "was edited" in err[0]
