"""Self-contained runs (issue 22, part 2): a run directory holds the files its scenario
references (a user's URDF and its meshes) and the robot's kinematics, so that moved
elsewhere, with the original files deleted, it re-runs, plots, replays, views and animates,
and is viewed without Pinocchio."""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from redservo import load_run
from redservo.cli.entry import main
from redservo.errors import ScenarioError
from redservo.robots.urdf import shipped_urdf
from redservo.runs.files import RunFileWarning
from redservo.scenario import load_scenario

pytest.importorskip("pinocchio")

_SCENARIO = """
name = "my-panda"
[robot]
urdf = "{urdf}"
q0 = [0.0, -0.785, 0.0, -2.8, 0.0, 1.571, 0.785]
qddot_max = 15.0
[[objects]]
name = "target"
kind = "points"
points = [[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]]
pose_in_camera = {{ translation = [-0.071, 0.043, 0.583], rotvec = [-0.22, -0.272, -0.39] }}
[[features]]
kind = "point"
object = "target"
[task]
desired_pose = {{ translation = [0.0, 0.0, 0.338] }}
[control]
method = "iterative-smooth"
[simulation]
max_iterations = 12
"""


def _user_files(root: Path) -> Path:
    """A user's URDF (the shipped Panda) naming three meshes: relative, package:// and
    absolute; returns the scenario file, which names the URDF by a relative path."""
    robot = root / "ws" / "my_robot"
    (robot / "meshes").mkdir(parents=True)
    (robot / "meshes" / "link0.stl").write_bytes(b"solid link0\nendsolid\n")
    (root / "elsewhere.stl").write_bytes(b"solid hand\nendsolid\n")
    visuals = (
        '<visual><geometry><mesh filename="meshes/link0.stl"/></geometry></visual>'
        '<visual><geometry><mesh filename="package://my_robot/meshes/link0.stl"/></geometry>'
        "</visual>"
        f'<visual><geometry><mesh filename="{root / "elsewhere.stl"}"/></geometry></visual>'
        '<visual><geometry><mesh filename="meshes/gone.stl"/></geometry></visual>'
    )
    text = shipped_urdf("panda").read_text(encoding="utf-8")
    text = text.replace('<link name="panda_link0">', f'<link name="panda_link0">{visuals}', 1)
    assert visuals in text
    (robot / "panda.urdf").write_text(text, encoding="utf-8")
    scenario = root / "scenarios" / "mine.toml"
    scenario.parent.mkdir()
    scenario.write_text(_SCENARIO.format(urdf="../ws/my_robot/panda.urdf"))
    return scenario


def _block_pinocchio(monkeypatch: pytest.MonkeyPatch) -> None:
    import redservo.robots.urdf as urdf

    monkeypatch.setitem(sys.modules, "pinocchio", None)  # import pinocchio raises ImportError
    monkeypatch.setattr(urdf, "_PIN", None)


def test_a_moved_run_works_without_its_original_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = _user_files(tmp_path / "user")
    run = tmp_path / "run"
    with pytest.warns(RunFileWarning, match="elsewhere.stl"):
        assert main(["run", str(scenario), "--out", str(run), "-q", "--no-plot"]) == 0
    # The URDF and its meshes are in the run, named relatively; the missing mesh is listed.
    import tomllib

    saved = tomllib.loads((run / "scenario.toml").read_text())
    assert saved["robot"]["urdf"] == "files/panda.urdf"  # relative to the run directory
    copied = json.loads((run / "run.json").read_text())["files"]
    assert "files/panda.urdf" in copied["copied"] and "files/meshes/link0.stl" in copied["copied"]
    assert any("gone.stl" in m for m in copied["missing"])
    urdf_copy = (run / "files" / "panda.urdf").read_text()
    assert "package://" not in urdf_copy
    # A mesh outside the robot's folder is not copied into a run made to be shared.
    assert not (run / "files" / "meshes" / "elsewhere.stl").exists()
    assert any("elsewhere.stl" in m and "outside" in m for m in copied["refused"])

    moved = tmp_path / "far" / "away"
    shutil.move(str(run), moved)
    shutil.rmtree(tmp_path / "user")
    capsys.readouterr()

    # Re-run: the same run again.
    again = tmp_path / "again"
    assert main(["run", str(moved / "scenario.toml"), "--out", str(again), "-q", "--no-plot"]) == 0
    assert load_run(again).summary["iterations"] == load_run(moved).summary["iterations"]
    np.testing.assert_array_equal(load_run(again).arrays["q"], load_run(moved).arrays["q"])

    # View and animate without Pinocchio: the logged kinematics replace the robot.
    _block_pinocchio(monkeypatch)
    with pytest.raises(ScenarioError, match="Pinocchio"):
        load_run(moved).experiment(logged=False)
    from redservo.viewer import pick_run
    from redservo.viewer.playback import Playback

    pb = Playback(pick_run(moved))
    for k in pb.frames(4):
        frame = pb.frame(k)
        assert frame.links and np.all(np.isfinite(frame.bMc))
    # What `redservo plot` needs of the run beyond its log (drawing is tested in test_runs).
    from redservo.runs.replot import _context

    context = _context(load_run(moved))
    assert context.joint_names == load_run(moved).joint_names and context.camera is not None
    if all(importlib.util.find_spec(m) for m in ("matplotlib", "imageio", "PIL")):
        gif = tmp_path / "run.gif"
        assert main(["animate", str(moved), "--out", str(gif), "--frames", "2", "-q"]) == 0
        assert gif.stat().st_size > 0


def test_the_logged_robot_equals_the_run_robot_bit_for_bit(tmp_path: Path) -> None:
    from redservo.experiment.build import build
    from redservo.runs.kinematics import LoggedRobot

    exp = build(load_scenario("panda-urdf-4points"))
    result = exp.run(max_iterations=6)
    result.save(tmp_path)
    logged = LoggedRobot(tmp_path / "kinematics.npz")
    for q in result.log.q:
        assert np.array_equal(logged.fkine(q), exp.robot.fkine(q, check_limits=False))
        assert np.array_equal(logged.jacobian(q), exp.robot.jacobian(q, check_limits=False))
        want = exp.robot.link_poses(q, check_limits=False)
        got = logged.link_poses(q)
        assert list(got) == list(want)
        assert all(np.array_equal(got[n], want[n]) for n in want)
    with pytest.raises(Exception, match="logged only at the run's own configurations"):
        logged.fkine(result.log.q[0] + 1e-3)


def test_a_moved_campaign_replays_without_its_original_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = _user_files(tmp_path / "user")
    campaign = tmp_path / "user" / "camp.toml"
    campaign.write_text(
        f'scenario = "{scenario.as_posix()}"\nmethods = ["gpm"]\nsamples = 2\n'
        "[target]\ntranslation = [[-0.01, 0.01], [-0.01, 0.01], [-0.01, 0.01]]\n"
    )
    out = tmp_path / "camp"
    args = ["campaign", str(campaign), "--out", str(out), "--workers", "1", "-q", "--no-plot"]
    with pytest.warns(RunFileWarning, match="elsewhere.stl"):
        code = main(args)
    if code != 0:
        pytest.fail(capsys.readouterr().err)
    assert (out / "files" / "panda.urdf").is_file()
    moved = tmp_path / "moved"
    shutil.move(str(out), moved)
    shutil.rmtree(tmp_path / "user")
    replay = ["replay", str(moved), "--sample", "1", "--method", "gpm", "-q", "--no-plot"]
    assert main(replay) == 0, capsys.readouterr().err
    assert "matches the campaign's stored row" in capsys.readouterr().out


def test_a_missing_absolute_urdf_is_not_said_to_be_relative(tmp_path: Path) -> None:
    text = _SCENARIO.format(urdf=(tmp_path / "nowhere" / "robot.urdf").as_posix())
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(tmp_path / "s.toml")
    assert "does not exist" in str(info.value) and "relative" not in str(info.value)
    (tmp_path / "r.toml").write_text(_SCENARIO.format(urdf="sub/robot.urdf"))
    with pytest.raises(ScenarioError, match="read relative to the scenario file's folder"):
        load_scenario(tmp_path / "r.toml")


def test_a_camera_file_is_copied_and_named_relatively(tmp_path: Path) -> None:
    pytest.importorskip("cv2")
    from redservo.calibration.files import save_camera
    from redservo.camera import Camera

    calib = save_camera(tmp_path / "calib" / "wrist.yaml", Camera(px=580.0, py=585.0))
    text = _SCENARIO.format(urdf="panda") + '[camera]\nfile = "../calib/wrist.yaml"\n'
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "cam.toml").write_text(text)
    run = tmp_path / "run"
    assert (
        main(["run", str(tmp_path / "s" / "cam.toml"), "--out", str(run), "-q", "--no-plot"]) == 0
    )
    import tomllib

    saved = tomllib.loads((run / "scenario.toml").read_text())
    assert saved["camera"]["file"] == "files/wrist.yaml"  # relative to the run directory
    calib.unlink()
    assert main(["run", str(run / "scenario.toml"), "--out", str(tmp_path / "again"), "-q",
                 "--no-plot"]) == 0  # fmt: skip
    assert load_run(tmp_path / "again").summary["iterations"] == load_run(run).summary["iterations"]


def test_a_missing_absolute_camera_file_is_not_said_to_be_relative(tmp_path: Path) -> None:
    gone = (tmp_path / "nowhere" / "wrist.yaml").as_posix()
    text = _SCENARIO.format(urdf="panda") + f'[camera]\nfile = "{gone}"\n'
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(tmp_path / "s.toml")
    assert "does not exist" in str(info.value) and "relative" not in str(info.value)
