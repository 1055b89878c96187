"""Scenarios on MJCF robots (issue 30 item 5 and its target: a Menagerie robot, Panda and UR5e,
converges on a 4-point task with self-collision on); ``[robot] kind = "mjcf"``'s bad input."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="MJCF robots need redservo[mujoco]")

import redservo
from redservo.cli.entry import main
from redservo.errors import ScenarioError
from redservo.experiment.build import build
from redservo.robots import MJCFRobot, shipped_mjcf
from redservo.scenario import load_scenario

SCENARIOS = Path(redservo.__file__).parent / "scenarios"


@pytest.mark.parametrize("name", ["menagerie-panda-4points", "menagerie-ur5e-4points"])
def test_menagerie_robot_converges_with_self_collision_on(
    name: str, tmp_path: Path, capsys
) -> None:
    out = tmp_path / "run"
    assert main(["run", name, "--out", str(out), "--no-plot", "-q"]) == 0
    assert "converged" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["success"] and summary["collision"] is None
    assert summary["min_distance"] > 0.01  # never closer than d_safe: no self-collision
    sc = load_scenario(name)
    assert sc.spec.collision is not None and sc.spec.collision.self


def test_the_menagerie_panda_runs_like_the_urdf_panda() -> None:
    pytest.importorskip("pinocchio", reason="the URDF path needs redservo[urdf]")
    from redservo.scenario import apply_overrides

    sets = ["simulation.max_iterations=40", "collision.self=false"]
    mj = build(apply_overrides(load_scenario("menagerie-panda-4points"), sets))
    assert isinstance(mj.robot, MJCFRobot)
    urdf = build(apply_overrides(load_scenario("panda-urdf-4points"), sets[:1])).run()
    np.testing.assert_allclose(mj.run().log.q, urdf.log.q, atol=1e-9)


def _scenario(tmp_path: Path, old: str, new: str) -> Path:
    text = (SCENARIOS / "menagerie-ur5e-4points.toml").read_text()
    assert old in text
    (tmp_path / "ur5e.xml").write_text(shipped_mjcf("ur5e").read_text())
    text = text.replace('file = "ur5e"', 'file = "ur5e.xml"').replace(old, new)
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


def test_a_file_path_is_read_relative_to_the_scenario(tmp_path: Path) -> None:
    exp = build(load_scenario(_scenario(tmp_path, 'tip = "camera"', 'tip = "camera"')))
    assert isinstance(exp.robot, MJCFRobot)
    assert exp.robot.path == (tmp_path / "ur5e.xml").resolve()


@pytest.mark.parametrize(
    ("old", "new", "key", "says"),
    [
        ('file = "ur5e"', 'file = "missing.xml"', "robot.file", "no such file"),
        ('file = "ur5e"', 'file = "ur6"', "robot.file", "unknown shipped MJCF 'ur6'"),
        ('tip = "camera"', 'tip = "flange"', "robot.tip", "neither a site, a camera nor a body"),
        ('tip = "camera"', 'tip = "camera"\nbase = "table"', "robot.base", "not a body"),
        ('tip = "camera"', 'tip = "camera"\nurdf = "ur5e"', "robot.kind", "give one of"),
        ('tip = "camera"', 'tip = "camera"\ncamera_link = "x"', "robot.camera_link", "only with"),
        ('kind = "mjcf"', 'kind = "sdf"', "robot.kind", "mjcf"),
    ],
)
def test_bad_robot_keys_are_one_error_naming_the_key(
    tmp_path: Path, old: str, new: str, key: str, says: str
) -> None:
    path = _scenario(tmp_path, old, new)
    if old.startswith("file"):
        path.write_text(path.read_text().replace('file = "ur5e.xml"', new))
    with pytest.raises(ScenarioError) as err:
        build(load_scenario(path))
    line = str(err.value)
    assert "\n" not in line and f"'{key}'" in line and says in line, line


def test_the_command_line_says_it_in_one_line_with_exit_code_2(tmp_path: Path, capsys) -> None:
    path = _scenario(tmp_path, 'tip = "camera"', 'tip = "flange"')
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-plot", "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "robot.tip" in err and "Traceback" not in err


def test_the_mjcf_robot_models_its_collision_start_check(tmp_path: Path) -> None:
    # A start in self-collision is refused naming collision.self (the wrist folded on the arm).
    text = _scenario(
        tmp_path,
        "q0 = [0.0, -1.9, 1.9, -1.57, -1.57, 0.0]",
        "q0 = [0.0, -1.9, 3.1, -1.57, -1.57, 0.0]",
    )
    with pytest.raises(ScenarioError, match=re.escape("'collision.self'")):
        build(load_scenario(text))


# -- campaigns and the MuJoCo backend -----------------------------------------------------------


def test_a_campaign_on_the_menagerie_panda_runs_its_samples(tmp_path: Path) -> None:
    # With self-collision on, the campaign runs on the object path (the compiled loop measures
    # no distance); the robot itself packs for the compiled loop (test_mjcf_robot.py).
    text = (SCENARIOS / "campaigns" / "panda-urdf-near-limits.toml").read_text()
    text = text.replace('scenario = "panda-urdf-4points"', 'scenario = "menagerie-panda-4points"')
    text = re.sub(r"^samples = \d+", "samples = 2", text, flags=re.M)
    (tmp_path / "c.toml").write_text(text)
    out = tmp_path / "out"
    args = ["campaign", str(tmp_path / "c.toml"), "--methods", "classical", "--workers", "1"]
    assert main([*args, "--no-plot", "-q", "--out", str(out)]) == 0
    rows = (out / "samples.csv").read_text().strip().splitlines()
    assert len(rows) == 3  # the header and one row per sample


def test_the_mujoco_backend_runs_the_mjcf_robot_through_our_writer() -> None:
    from redservo.physics.arm import MujocoArm
    from redservo.scenario import apply_overrides

    robot = MJCFRobot(shipped_mjcf("ur5e"), tip="camera")
    arm = MujocoArm(robot)
    rng = np.random.default_rng(5)
    for _ in range(10):
        q = rng.uniform(robot.q_min, robot.q_max)
        arm.set_q(q)
        assert np.abs(arm.camera_pose() - robot.fkine(q)).max() <= 1e-9
    sets = ['simulator.kind="mujoco"']
    result = build(apply_overrides(load_scenario("menagerie-ur5e-4points"), sets)).run()
    assert result.outcome == "converged"


def test_a_run_directory_carries_the_mjcf_and_its_meshes(tmp_path: Path) -> None:
    # The shipped UR5e with its wrist_3 geom as a (tiny) mesh under meshdir="assets".
    model = tmp_path / "model"
    (model / "assets").mkdir(parents=True)
    verts = [(-0.04, 0.06, -0.04), (0.04, 0.06, -0.04), (0.0, 0.1, 0.04), (0.0, 0.06, 0.04)]
    obj = "".join(f"v {x} {y} {z}\n" for x, y, z in verts) + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    (model / "assets" / "flange.obj").write_text(obj)
    xml = shipped_mjcf("ur5e").read_text()
    xml = xml.replace('autolimits="true"/>', 'autolimits="true" meshdir="assets"/>')
    xml = xml.replace("<worldbody>", '<asset><mesh file="flange.obj"/></asset>\n  <worldbody>')
    xml = xml.replace(
        '<geom class="eef_collision" pos="0 0.08 0" quat="1 1 0 0" size="0.04 0.02"/>',
        '<geom class="collision" type="mesh" mesh="flange"/>',
    )
    (model / "ur5e.xml").write_text(xml)
    text = (SCENARIOS / "menagerie-ur5e-4points.toml").read_text()
    text = text.replace('file = "ur5e"', 'file = "model/ur5e.xml"')
    text = re.sub(r"^max_iterations = \d+", "max_iterations = 5", text, flags=re.M)
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "run"
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(out), "--no-plot", "-q"]) == 0
    assert (out / "files" / "ur5e.xml").is_file()
    assert (out / "files" / "assets" / "flange.obj").read_text() == obj
    moved = tmp_path / "moved"
    out.rename(moved)
    (model / "ur5e.xml").unlink()  # the run directory needs nothing outside it
    again = tmp_path / "again"
    assert main(["run", str(moved / "scenario.toml"), "--out", str(again), "--no-plot", "-q"]) == 0


def test_without_distances_the_compiled_campaign_loop_takes_the_mjcf_robot() -> None:
    pytest.importorskip("numba", reason="the compiled loop needs redservo[fast]")
    from redservo.campaign import fastloop
    from redservo.campaign.engine import FAST_PATH
    from redservo.campaign.fastloop import campaign_law, fast_run
    from redservo.scenario import apply_overrides

    base = load_scenario("menagerie-ur5e-4points")
    exp = build(apply_overrides(base, ["collision.self=false"]))
    assert fastloop.fast_reason(exp, campaign_law(exp, "classical", None)) is None
    summary, path = fast_run(exp, "classical", None)
    assert path == FAST_PATH and summary is not None and summary.outcome == "converged"
    with_self = build(base)
    reason = fastloop.fast_reason(with_self, campaign_law(with_self, "classical", None))
    assert reason is not None and "no compiled collision geometry" in reason


def test_redservo_list_names_the_shipped_mjcf_robots(capsys) -> None:
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    group = out.split('MJCF robots (robot.kind = "mjcf"', 1)[1].split("\n\n", 1)[0]
    assert "panda" in group and "menagerie-panda-4points" in group, group
    assert "ur5e" in group and "6 joints; scenarios: menagerie-ur5e-4points" in group, group
