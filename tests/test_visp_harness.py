"""ViSP's step side by side (benchmarks/visp, benchmarks/bench_object_path.py --visp): the
harness is driven by its line protocol, timed in the same rounds as the other items, its
numbers compared with redservo's on the same inputs, and a missing harness is one line and
exit code 2. A fake harness (a Python script speaking the protocol) stands for ViSP; the
real one, when built (sh benchmarks/visp/build.sh), is checked against redservo too."""

from __future__ import annotations

import json
import os
import stat
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from redservo.bench.cases import SQUARE
from tests.load_module import ROOT, load_module

bench = load_module("benchmarks/bench_object_path.py")
sys.path.insert(0, str(ROOT / "benchmarks"))
from visp import harness as vh  # noqa: E402 -- benchmarks/ on the path first

REAL = ROOT / "benchmarks" / "visp" / "visp_step"
FAKE = """#!{python}
import json, sys
data = json.load(open({data!r}))
ready = False
for line in sys.stdin:
    words = line.split()
    if not words:
        print("error: empty"); sys.stdout.flush(); continue
    cmd = words[0]
    if cmd == "version":
        print("visp 3.5.0-fake")
    elif cmd == "setup":
        ready = len(words) == 68
        print("ok" if ready else "error: malformed setup line")
    elif cmd == "check" and ready:
        for name in ("qdot", "e", "L", "J"):
            print(name, " ".join(repr(x) for x in data[name]))
        print("end")
    elif cmd == "time" and ready:
        print(int(words[1]) * 7000, int(words[1]) * 9000)
    else:
        print("error: " + cmd)
    sys.stdout.flush()
"""


def _case() -> Any:
    return bench.the_case()


def _ours(case: Any) -> dict[str, Any]:
    """redservo's J, L, e at the case's state and the classical law's q̇ on J1 = L J, e."""
    from redservo import JointLimits, make_law

    bMc, J = case.robot.kinematics(case.q)
    st = case.task.evaluate(case.scene, bMc, J, 0.0)
    lim = JointLimits(case.limits.q_min, case.limits.q_max)
    res = make_law("classical")(J1=st.L @ J, e1=st.e, q=case.q, limits=lim, lam=0.5, dt=0.04)
    return {"qdot": res.qdot, "e": st.e, "L": st.L, "J": J}


def _fake(tmp_path: Path, numbers: dict[str, Any]) -> Path:
    data = tmp_path / "numbers.json"
    data.write_text(json.dumps({k: np.asarray(v).ravel().tolist() for k, v in numbers.items()}))
    path = tmp_path / "visp_step"
    path.write_text(FAKE.format(python=sys.executable, data=str(data)))
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return path


def test_the_harness_is_driven_by_its_protocol_and_compared_on_the_same_inputs(
    tmp_path: Path,
) -> None:
    case = _case()
    ours = _ours(case)
    step = vh.VispStep(_fake(tmp_path, ours), case)
    try:
        assert step.version == "visp 3.5.0-fake"
        assert step.per_call_us(1000, cpu=True) == 7.0
        assert step.per_call_us(1000, cpu=False) == 9.0
        visp = step.check()
        assert visp["L"].shape == (8, 6) and visp["J"].shape == (6, 6)
        agree = vh.agreement(case, visp)
        assert agree == dict.fromkeys(agree, 0.0)  # our own numbers: no difference
        visp["J"] = visp["J"] + 1e-9
        assert vh.agreement(case, visp)["J"] == pytest.approx(1e-9, rel=1e-6)
    finally:
        step.close()


def test_the_setup_line_gives_the_case_in_the_protocols_order() -> None:
    case = _case()
    words = vh.setup_line(case).split()
    assert words[0] == "setup" and len(words) == 1 + 6 + 16 + 16 + 12 + 1 + 16
    values = np.array([float(w) for w in words[1:]])
    assert values[:6].tolist() == case.q.tolist()
    bMc, _ = case.robot.kinematics(case.q)
    assert values[6:22].tolist() == case.scene.cMo("t", bMc, 0.0).ravel().tolist()
    assert values[38:50].reshape(4, 3).tolist() == SQUARE.tolist()
    assert values[50] == case.lam
    assert values[51:].tolist() == case.robot.eMc.ravel().tolist()


def test_visp_is_timed_in_each_round_among_the_other_items() -> None:
    order: list[str] = []

    class Visp:
        def per_call_us(self, batch: int, cpu: bool) -> float:
            order.append(f"visp {batch} {cpu}")
            return 7.0

    named = [("a", lambda: order.append("a")), ("visp step", Visp())]
    res = bench.measure(named, rounds=2, batch=3, cpu=True)
    assert res["visp step"]["median_us"] == 7.0
    warm = ["a"] * 50 + ["visp 50 True"]
    assert order == [*warm, "a", "a", "a", "visp 3 True", "a", "a", "a", "visp 3 True"]


def test_the_ratios_use_the_visp_time_of_the_run() -> None:
    names = (*bench.VISP_TARGETS, "Controller.step", "Controller.step .qdot")
    res = {name: {"median_us": 16.0} for name in names}
    res["compiled measured"] = {"median_us": 10.0}
    res["Controller.step .qdot"] = {"median_us": 12.5}
    res["visp step"] = {"median_us": 8.0}
    lines = bench.ratio_lines(res)
    assert "Controller.step / compiled measured step: 1.60x (target ≤ 1.3x: missed)" in lines
    assert "Controller.step .qdot / compiled measured step: 1.25x (target ≤ 1.3x: met)" in lines
    assert "path classical / ViSP (8.00 µs, this run): 2.00x (target ≤ 2.5x: met)" in lines
    assert "compiled measured / ViSP (8.00 µs, this run): 1.25x (target ≤ 1.3x: met)" in lines
    assert "compiled qp / ViSP (8.00 µs, this run): 2.00x (target ≤ 1.6x: missed)" in lines
    del res["visp step"]
    assert any("(7.30 µs, issue 29)" in line for line in bench.ratio_lines(res))


@pytest.mark.parametrize("kind", ["missing", "not executable", "off protocol"])
def test_a_harness_that_cannot_run_is_one_line_and_exit_code_2(
    kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "visp_step"
    if kind == "not executable":
        path.write_text("#!/bin/sh\n")
    elif kind == "off protocol":
        path.write_text(f"#!{sys.executable}\nimport sys\nfor l in sys.stdin: print('what?')\n")
        path.chmod(0o755)
    with pytest.raises(SystemExit) as info:
        bench.with_visp([], path, _case())
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and "Traceback" not in err


@pytest.mark.skipif(
    not (REAL.is_file() and os.access(REAL, os.X_OK)),
    reason="the ViSP harness is not built (sh benchmarks/visp/build.sh; needs libvisp-dev)",
)
def test_visp_and_redservo_agree_on_the_same_case() -> None:
    """ViSP 3.5's own Afma6 Jacobian, interaction matrix, error and command against
    redservo's: the classical law on the same J1 and e to 1e-12 (measured: 3e-15)."""
    case = _case()
    step = vh.VispStep(REAL, case)
    try:
        agree = vh.agreement(case, step.check())
        assert step.per_call_us(10, cpu=True) > 0.0
    finally:
        step.close()
    assert max(agree.values()) < 1e-12, agree


def test_the_control_step_benchmark_times_visp_in_the_same_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    control = load_module("benchmarks/bench_control_step.py")
    fake = _fake(tmp_path, _ours(_case()))
    assert control.visp_rounds(fake, 3, 100) == [9.0, 9.0, 9.0]  # the wall clock, as redservo bench
    rows = [{"case": "afma6-4points", "path": "compiled", "method": "qp", "median_us": 11.2}]
    saved = tmp_path / "bench.json"
    saved.write_text(json.dumps({"rows": rows, "visp": {"median_us": 7.0}}))
    monkeypatch.setattr(sys, "argv", ["bench_control_step.py", "--from", str(saved)])
    control.main()
    out = capsys.readouterr().out
    assert "ViSP's, measured in this run" in out
    assert "afma6-4points, qp: 11.2 µs = 1.60x ViSP (7 µs; target ≤ 1.6x): met" in out
    with pytest.raises(SystemExit) as info:
        control.visp_rounds(tmp_path / "absent", 1, 1)
    assert info.value.code == 2
