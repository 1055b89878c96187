"""Shipped scenarios on robots loaded from our URDFs (issue: any robot from its URDF)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio", reason="the URDF scenarios need redservo[urdf] (pin)")

from redservo.cli import main
from redservo.experiment import build
from redservo.scenario import apply_overrides, load_scenario


def test_ur5e_servoes_on_four_points_through_redservo_run(tmp_path, capsys) -> None:
    out = tmp_path / "ur5e"
    assert main(["run", "ur5e-4points", "--out", str(out), "--no-plot", "-q"]) == 0
    text = capsys.readouterr().out
    assert "converged" in text and "success" in text
    assert (out / "summary.json").exists()


def test_the_panda_from_urdf_runs_like_the_dh_panda() -> None:
    sets = ["simulation.max_iterations=60"]
    dh = build(apply_overrides(load_scenario("panda-4points"), sets)).run()
    urdf = build(apply_overrides(load_scenario("panda-urdf-4points"), sets)).run()
    assert len(dh.log) == len(urdf.log)
    np.testing.assert_allclose(urdf.log.q, dh.log.q, atol=1e-9)
    np.testing.assert_allclose(urdf.log.qdot, dh.log.qdot, atol=1e-8)
