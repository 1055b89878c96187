"""The benchmark harness runs and reports every path (timings themselves live in benchmarks/)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from redservo.bench.cases import bench_cases
from redservo.bench.steps import MAIN_CASES, _reference, run_bench
from redservo.cli.entry import main
from redservo.redundancy import make_law


def test_bench_reports_every_path_with_progress() -> None:
    pytest.importorskip("numba", reason="the compiled path needs numba")
    seen: list[tuple[int, int, str]] = []
    res = run_bench(
        repeat=4,
        rounds=2,
        methods=("classical", "qp"),
        cases=("afma6-4points", "afma6-moments"),
        scaling=(6,),
        reference=False,
        throughput_steps=5,
        first_call=False,
        progress=lambda done, total, label: seen.append((done, total, label)),
    )
    paths = {(r.case, r.method, r.path) for r in res.rows}
    for case in ("afma6-4points", "afma6-moments"):
        for method in ("classical", "qp"):
            assert {(case, method, p) for p in ("compiled", "api", "law")} <= paths
    assert ("afma6-moments", "-", "compiled") in paths and ("dh-6", "qp", "law") in paths
    assert all(r.median_us > 0 and r.rounds == 2 and r.batch == 2 for r in res.rows)
    assert seen[-1][0] == seen[-1][1] == 2 * len(res.rows)
    md = res.markdown
    assert "interleaved rounds" in md and "| afma6-4points | classical |" in md and "n = 6" in md
    assert "target" not in md.lower() and "Steps per second" in md
    json.dumps(res.to_json())


def test_reference_path_runs_without_numba() -> None:
    pytest.importorskip("numba", reason="compared with the compiled path")
    rows = _reference(["afma6-gaze"], ["classical"], 1, 1)
    assert [(r.case, r.method, r.path) for r in rows] == [("afma6-gaze", "classical", "reference")]
    assert rows[0].median_us > 0


def test_cases_are_what_the_issue_describes() -> None:
    cases = {c.name: c for c in bench_cases(scaling=(6, 50))}
    assert set(MAIN_CASES) <= set(cases) and {"dh-6", "dh-50"} <= set(cases)
    four = cases["afma6-4points"]
    bMc = four.robot.fkine(four.q)
    cMo = four.scene.cMo("t", bMc)
    assert cMo[2, 3] == pytest.approx(0.6)  # the square's centre 0.6 m ahead
    assert np.degrees(np.arctan2(cMo[1, 0], cMo[0, 0])) == pytest.approx(80.0)
    assert four.task.m == 6 and cases["dh-50"].robot.n == 50
    active = cases["panda-6d-bounds"]
    bMc, J = active.robot.kinematics(active.q)
    st = active.task.evaluate(active.scene, bMc, J)
    kw = {"J1": st.J1, "e1": st.e1, "q": active.q, "limits": active.limits, "lam": 0.5, "dt": 0.04}
    sns = make_law("sns")(**kw).diagnostics
    qp = make_law("qp")(**kw).diagnostics
    assert sns.scale is not None and sns.scale < 1.0 and sns.critical  # sns saturates
    assert "solver: none" not in qp.info[0]  # qp calls its solver


def test_bench_command_writes_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("numba", reason="the compiled path needs numba")
    out = tmp_path / "bench.json"
    args = ["bench", "--repeat", "2", "--rounds", "1", "--methods", "classical"]
    args += ["--cases", "afma6-gaze", "--scaling", "none", "--no-reference", "--json", str(out)]
    assert main(args) == 0
    data = json.loads(out.read_text())
    assert {r["path"] for r in data["rows"]} == {"compiled", "api", "law"}
    captured = capsys.readouterr()
    assert "afma6-gaze" in captured.out and "bench " in captured.err  # progress on stderr
