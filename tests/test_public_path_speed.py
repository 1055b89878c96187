"""The public path's per-call work (issue 29 item 3): a law call with the signature seen just
before and a compiled Controller step without output options skip what cannot have changed,
with the same command, flags and task state bit for bit as the full path."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

import redservo.control.engine as engine
import redservo.redundancy.kernel_call as kc
from redservo import Controller, JointLimits, make_law
from redservo.bench.cases import bench_cases
from redservo.control import Measurement

LAWS = ("classical", "gpm", "gpm-auto", "iterative", "iterative-smooth", "directional")


def _inputs(seed: int, prev: bool) -> dict[str, Any]:
    """Inputs near the limits with rate limits: events from the law and its safety layer."""
    rng = np.random.default_rng(seed)
    n, m = 6, int(rng.integers(1, 5))
    lim = JointLimits(
        -np.ones(n), np.ones(n), rho=0.1, qdot_max=np.full(n, 0.3), qddot_max=np.full(n, 2.0)
    )
    return {
        "J1": rng.normal(size=(m, n)),
        "e1": 5.0 * rng.normal(size=m),
        "q": rng.uniform(-0.99, 0.99, n),
        "limits": lim,
        "lam": 0.8,
        "dt": 0.04,
        "qdot_prev": rng.uniform(-0.3, 0.3, n) if prev else None,
    }


def _same_diag(a: Any, b: Any) -> None:
    """Field by field (arrays by their bytes), the events with their values."""
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            assert np.asarray(x).tobytes() == np.asarray(y).tobytes(), f.name
        else:
            assert x == y, f.name
    assert a.flags == b.flags


def _same(a: Any, b: Any) -> None:
    assert a.qdot.tobytes() == b.qdot.tobytes()
    _same_diag(a.diagnostics, b.diagnostics)


@pytest.mark.parametrize("method", LAWS)
@pytest.mark.parametrize("prev", [False, True])
def test_a_repeated_signature_skips_the_packing_and_gives_the_same_result(
    method: str, prev: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The second call with the same shapes, limits object and options does not look up its
    packs again (on today's main every call re-derives them), and the command and flags of
    every call are bit for bit those of a fresh law taking the full path."""
    law = make_law(method)
    kw = _inputs(1, prev)
    first = law(**kw)
    _same(first, make_law(method)(**kw))

    def refuse(*_: Any) -> Any:
        raise AssertionError("packs looked up again")

    monkeypatch.setattr(kc, "_bound", refuse)
    monkeypatch.setattr(kc, "_law_pack", refuse)
    fresh = {k: v.copy() if isinstance(v, np.ndarray) else v for k, v in kw.items()}
    again = law(**fresh)  # new arrays, the same limits object
    monkeypatch.undo()
    _same(again, first)
    for seed in range(2, 8):  # new values (and shapes): the same as a fresh law's
        kw = _inputs(seed, prev)
        _same(law(**kw), make_law(method)(**kw))


def test_a_changed_option_or_limits_object_takes_the_full_path_again() -> None:
    kw = _inputs(3, True)
    law = make_law("iterative-smooth")
    law(**kw)
    law.set_safety(shield=False)
    _same(law(**kw), make_law("iterative-smooth", shield=False)(**kw))
    other = JointLimits(-np.ones(6), np.ones(6), rho=0.2, qdot_max=np.full(6, 0.1))
    kw["limits"] = other
    _same(law(**kw), make_law("iterative-smooth", shield=False)(**kw))


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("q", np.zeros((6, 1))),
        ("q", np.zeros(5)),
        ("e1", np.zeros(3)),
        ("qdot_prev", np.zeros(5)),
        ("lam", -1.0),
        ("dt", float("nan")),
    ],
)
def test_a_repeated_signature_still_names_a_bad_argument(name: str, value: Any) -> None:
    kw = _inputs(4, True)
    kw["J1"], kw["e1"] = kw["J1"][:1].copy(), kw["e1"][:1].copy()
    law = make_law("classical")
    law(**{**kw, "e1": np.zeros(kw["J1"].shape[0])})  # the signature is known
    kw[name] = value
    with pytest.raises(Exception) as info:
        law(**kw)
    assert getattr(info.value, "argument", None) == name


@pytest.mark.parametrize(
    ("name", "value"),
    [("q", lambda q: q.astype(np.float32)), ("e1", lambda e: np.repeat(e, 2)[::2])],
)
def test_a_valid_input_off_the_signature_gives_a_fresh_laws_result(name: str, value: Any) -> None:
    kw = _inputs(5, True)
    law = make_law("gpm")
    law(**kw)
    kw[name] = value(kw[name])
    _same(law(**kw), make_law("gpm")(**kw))


def _controller(**options: Any) -> tuple[Controller, Any, Measurement]:
    case = next(c for c in bench_cases(scaling=()) if c.name == "afma6-4points")
    robot, scene, task, q = case.robot, case.scene, case.task, case.q
    bMc, J = robot.kinematics(q)
    st = task.evaluate(scene, bMc, J, 0.0)
    law = make_law("iterative-smooth")
    ctl = Controller(robot, task, law, case.limits, lam=case.lam, dt=case.dt, **options)
    return ctl, q, Measurement(st.s, tuple(st.inv_depth))


def test_the_compiled_step_skips_an_output_stage_with_nothing_to_do(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """No saturation, camera-motion limit or collision set: the output stage is not run (on
    today's main it runs and returns the command unchanged), and the step is bit for bit
    the object path's."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    calls = []
    monkeypatch.setattr(engine, "shape_output", lambda *a: calls.append(a))
    prev = np.zeros(q.shape[0])
    for k in range(3):
        got, want = (
            ctl.step(q, meas, 0.04 * k, qdot_prev=prev),
            ref.step(q, meas, 0.04 * k, qdot_prev=prev),
        )
        assert got.qdot.tobytes() == want.qdot.tobytes()
        _same_diag(got.diagnostics, want.diagnostics)
        assert got.saturated is want.saturated is False
        for a, b in zip(got.state, want.state, strict=True):
            assert np.asarray(a).tobytes() == np.asarray(b).tobytes()
        assert ctl.stage == "guard"
        prev = got.qdot
    assert calls == []
    assert ctl._compiled is not None and ctl.engine == "compiled"


def test_the_compiled_step_keeps_the_output_stage_when_it_is_set() -> None:
    ctl, q, meas = _controller(qdot_saturation=1e-3)
    ref, _, _ = _controller(qdot_saturation=1e-3, engine="python")
    got, want = ctl.step(q, meas, 0.0, qdot_prev=None), ref.step(q, meas, 0.0, qdot_prev=None)
    assert got.saturated and want.saturated
    assert got.qdot.tobytes() == want.qdot.tobytes()
    assert np.max(np.abs(got.qdot)) <= 1e-3


@pytest.mark.parametrize("saturation", [None, 1e-3])
def test_the_history_keeps_one_copy_of_each_command_shared_with_the_diagnostics(
    saturation: float | None,
) -> None:
    """A compiled step whose safety layer raised events copies ``q`` and ``q̇`` once, for its
    lazy diagnostics and the command history alike (on today's main each copied them
    again); the history holds what was sent, whatever the caller writes afterwards."""
    ctl, q, meas = _controller(qdot_saturation=saturation)
    ref, _, _ = _controller(qdot_saturation=saturation, engine="python")
    q = q.copy()
    got, want = ctl.step(q, meas, 0.5, qdot_prev=None), ref.step(q, meas, 0.5, qdot_prev=None)
    sent = got.qdot.copy()
    (cmd,) = ctl.history._cmds
    (ref_cmd,) = ref.history._cmds
    safety = got.diagnostics._build[1][6]  # the lazy diagnostics' (q, q̇, dt, limits)
    assert safety is not None  # this case's safety layer scales the velocity
    if saturation is None:
        assert cmd.q is safety[0] and cmd.qdot is safety[1]
    got.qdot[:] = 9.0
    q[:] = 0.0
    assert cmd.t == ref_cmd.t == 0.5
    assert cmd.q.tobytes() == ref_cmd.q.tobytes() and cmd.q is not q
    assert cmd.qdot.tobytes() == sent.tobytes() == want.qdot.tobytes()
    _same_diag(got.diagnostics, want.diagnostics)


def test_the_object_path_benchmark_states_the_ratios_to_visp() -> None:
    from tests.load_module import load_module

    bench = load_module("benchmarks/bench_object_path.py")
    res = {name: {"median_us": 14.6} for name in bench.VISP_TARGETS}
    lines = bench.visp_lines(res, visp_us=7.3)
    assert lines[0] == "path classical / ViSP (7.30 µs, issue 29): 2.00x (target ≤ 2.5x: met)"
    assert lines[2].startswith("compiled measured / ViSP (7.30 µs, issue 29): 2.00x")
    assert "missed" in lines[2]
    assert lines[3] == "compiled qp / ViSP (7.30 µs, issue 29): 2.00x (target ≤ 1.6x: missed)"
    measured = bench.visp_lines(res, visp_us=8.0, measured=True)
    assert measured[0] == "path classical / ViSP (8.00 µs, this run): 1.82x (target ≤ 2.5x: met)"


def test_the_control_step_benchmark_states_the_compiled_steps_ratio_to_visp() -> None:
    import importlib.util
    from pathlib import Path

    path = Path(__file__).parents[1] / "benchmarks" / "bench_control_step.py"
    spec = importlib.util.spec_from_file_location("bench_control_step", path)
    assert spec is not None and spec.loader is not None
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    rows = [
        {"case": "afma6-4points", "path": "compiled", "method": "classical", "median_us": 9.49},
        {"case": "afma6-4points", "path": "compiled", "method": "qp", "median_us": 11.0},
        {"case": "afma6-4points", "path": "reference", "method": "qp", "median_us": 99.0},
        {"case": "panda-6d-bounds", "path": "compiled", "method": "qp", "median_us": 20.0},
    ]
    lines = bench.visp_check({"rows": rows}, visp_us=7.3)
    assert lines == [
        "afma6-4points, classical: 9.5 µs = 1.30x ViSP (7.3 µs; target ≤ 1.3x): met",
        "afma6-4points, qp: 11.0 µs = 1.51x ViSP (7.3 µs; target ≤ 1.6x): met",
    ]
