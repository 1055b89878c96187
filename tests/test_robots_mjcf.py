"""MJCF models (docs/robots.md, "MJCF models"): the page's example reads a serial MJCF arm into
an MJCFRobot whose camera pose is MuJoCo's, and an MJCF given as robot.urdf is refused in one
line that says what it is and what to write instead."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from redservo.errors import ScenarioError
from redservo.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]

ARM = """<mujoco model="arm3">
  <worldbody>
    <body name="base" pos="0 0 0.1" euler="0 0 30">
      <joint name="yaw" type="hinge" axis="0 0 1" range="-2.9 2.9"/>
      <geom type="capsule" size="0.04" fromto="0 0 0 0 0 0.3"/>
      <body name="upper" pos="0 0 0.3" euler="90 0 0">
        <joint name="shoulder" type="hinge" axis="0 0 1" range="-1.7 1.7"/>
        <geom type="capsule" size="0.04" fromto="0 0 0 0.4 0 0"/>
        <body name="slider" pos="0.4 0 0" quat="0.9238795 0 0.3826834 0">
          <joint name="reach" type="slide" axis="1 0 0" range="0 0.2"/>
          <geom type="box" size="0.05 0.05 0.05"/>
          <site name="camera" pos="0.1 0 0" euler="0 90 0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _recipe() -> str:
    text = (ROOT / "docs" / "robots.md").read_text(encoding="utf-8")
    section = text.split("## MJCF models", 1)[1]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)[0]


def test_the_docs_recipe_reads_an_mjcf_arm_exactly(tmp_path: Path, monkeypatch) -> None:
    mujoco = pytest.importorskip("mujoco")
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    monkeypatch.chdir(tmp_path)
    scope: dict[str, object] = {}
    exec(compile(_recipe(), "docs/robots.md", "exec"), scope)
    robot = scope["robot"]
    assert robot.joint_names == ("yaw", "shoulder", "reach")  # type: ignore[attr-defined]
    np.testing.assert_array_equal(robot.qdot_max, [2.0, 2.0, 0.5])  # type: ignore[attr-defined]
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    site = model.site("camera").id
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(model.jnt_range[:, 0], model.jnt_range[:, 1])
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        wMs = np.eye(4)
        wMs[:3, :3] = data.site_xmat[site].reshape(3, 3)
        wMs[:3, 3] = data.site_xpos[site]
        np.testing.assert_allclose(robot.fkine(q), wMs, atol=1e-12)  # type: ignore[attr-defined]


def test_an_mjcf_given_as_robot_urdf_is_named_for_what_it_is(tmp_path: Path) -> None:
    pytest.importorskip("pinocchio", reason="URDF robots need redservo[urdf] (pin)")
    from redservo.experiment.build import build

    (tmp_path / "arm.xml").write_text(ARM)
    text = (ROOT / "src/redservo/scenarios/panda-urdf-4points.toml").read_text()
    (tmp_path / "s.toml").write_text(text.replace('urdf = "panda"', 'urdf = "arm.xml"'))
    with pytest.raises(ScenarioError) as err:
        build(load_scenario(tmp_path / "s.toml"))
    line = str(err.value)
    assert "\n" not in line and "robot.urdf" in line, line
    assert "an MJCF (MuJoCo) model, not a URDF" in line and '"MJCF models"' in line, line
    assert "robot.kind = 'mjcf'" in line, line
