"""The Panda four-point scenario with every method and default settings (issue: safe on a real
arm): no command above the joint velocity limits, no limit crossed, the margin kept, and the
command line prints the diagnostics."""

from __future__ import annotations

import numpy as np
import pytest

from redservo import METHODS
from redservo.cli.entry import main
from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario


@pytest.fixture(scope="module")
def panda_runs():
    sc = apply_overrides(load_scenario("panda-4points"), ["simulation.max_iterations=200"])
    exp = build(sc)
    return exp, {m: exp.run(method=m) for m in METHODS}


@pytest.mark.parametrize("method", METHODS)
def test_every_method_is_safe_on_the_panda(panda_runs, method: str) -> None:
    exp, runs = panda_runs
    res = runs[method]
    lim = exp.limits
    assert lim.qdot_max is not None and lim.qddot_max is not None
    assert res.outcome != "joint_limit"
    qdot = res.log.qdot
    assert np.isfinite(qdot).all()
    assert np.all(np.abs(qdot) <= lim.qdot_max), "velocity limit exceeded"
    q_next = res.log.q + exp.options.dt * qdot
    assert np.all(q_next >= lim.safe_min) and np.all(q_next <= lim.safe_max)
    assert res.summary.velocity_violations == 0
    assert res.summary.peak_velocity_ratio <= 1.0
    assert res.summary.min_margin >= 0.01 - 1e-9


def test_the_papers_laws_succeed_safely_on_the_panda(panda_runs) -> None:
    _, runs = panda_runs
    for method in ("iterative-smooth", "gpm-auto"):
        full = build(load_scenario("panda-4points")).run(method=method)
        assert full.summary.success, (method, full.summary.to_dict())
    assert runs["classical"].summary.shield_activations > 0  # classical needs the shield
    assert not runs["classical"].summary.success


def test_cli_prints_the_diagnostics(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    assert main(["run", "panda-4points", "--method", "classical", "--out", str(out), "-q"]) == 0
    captured = capsys.readouterr()
    text = captured.out + captured.err
    assert "warning: shield-acted:" in text and "first at iteration" in text
    assert "no success" in text
