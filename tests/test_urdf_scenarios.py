"""Shipped scenarios on robots loaded from our URDFs (issue: any robot from its URDF)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pinocchio", reason="the URDF scenarios need redservo[urdf] (pin)")

import redservo
from redservo.cli.entry import main
from redservo.errors import ScenarioError
from redservo.experiment.build import build
from redservo.robots import shipped_urdf
from redservo.robots.panda import PANDA_QDDOT_MAX
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


# -- issue 17: the limits of a URDF robot are never silently lost ---------------------------------

SCENARIO = (Path(redservo.__file__).parent / "scenarios" / "panda-urdf-4points.toml").read_text()


def _scenario(tmp_path: Path, *, urdf: str | None = None, robot_keys: str = "") -> Path:
    """panda-urdf-4points without its [robot] qddot_max, optionally on another URDF text."""
    text = re.sub(r"^qddot_max.*$", robot_keys, SCENARIO, flags=re.M)
    if urdf is not None:
        (tmp_path / "arm.urdf").write_text(urdf)
        text = text.replace('urdf = "panda"', 'urdf = "arm.urdf"')
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return path


def test_urdf_panda_honours_the_datasheet_accelerations_without_a_scenario_key(
    tmp_path: Path,
) -> None:
    # Before: the URDF carried no acceleration limit and these runs reached 2.57-2.61x it.
    exp = build(
        apply_overrides(load_scenario(_scenario(tmp_path)), ["simulation.max_iterations=60"])
    )
    assert np.array_equal(exp.limits.qddot_max, PANDA_QDDOT_MAX)  # type: ignore[arg-type]
    for method in ("iterative-smooth", "gpm-auto", "sns", "classical"):
        result = exp.run(method=method)
        step = np.diff(np.vstack([np.zeros((1, 7)), result.log.qdot]), axis=0)
        ratio = np.max(np.abs(step) / (np.array(PANDA_QDDOT_MAX) * 0.04))
        assert ratio <= 1.0 + 1e-9, (method, ratio)
        assert result.summary.acceleration_violations == 0
        assert result.summary.peak_velocity_ratio is not None
        assert result.summary.peak_velocity_ratio <= 1.0 + 1e-9


def test_a_zero_velocity_in_the_urdf_is_a_scenario_error_unless_qdot_max_is_given(
    tmp_path: Path,
) -> None:
    broken = shipped_urdf("panda").read_text().replace('velocity="2.175"', 'velocity="0"', 1)
    with pytest.raises(ScenarioError) as info:
        build(load_scenario(_scenario(tmp_path, urdf=broken)))
    text = str(info.value)
    assert "robot.urdf" in text and "arm.urdf" in text and "'panda_joint1'" in text, text
    assert "qdot_max" in text
    # The scenario's qdot_max replaces the file's velocities (all of them).
    given = "qdot_max = [2.0, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]"
    path = _scenario(tmp_path, urdf=broken, robot_keys=given)
    exp = build(apply_overrides(load_scenario(path), ["simulation.max_iterations=40"]))
    assert exp.limits.qdot_max is not None and exp.limits.qdot_max[0] == 2.0
    summary = exp.run().summary
    assert summary.peak_velocity_ratio is not None and summary.velocity_violations == 0


def test_robot_qddot_max_gives_a_user_urdf_its_accelerations(tmp_path: Path) -> None:
    plain = re.sub(r"\s*<redservo:limit [^>]*/>", "", shipped_urdf("panda").read_text())
    assert build(load_scenario(_scenario(tmp_path, urdf=plain))).limits.qddot_max is None
    keys = "qddot_max = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]"
    exp = build(load_scenario(_scenario(tmp_path, urdf=plain, robot_keys=keys)))
    assert np.array_equal(exp.limits.qddot_max, PANDA_QDDOT_MAX)  # type: ignore[arg-type]
    with pytest.raises(ScenarioError, match=r"robot\.qddot_max.*7 entries"):
        build(load_scenario(_scenario(tmp_path, urdf=plain, robot_keys="qddot_max = [1.0, 2.0]")))
