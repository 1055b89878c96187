"""The MuJoCo backend (issue 23): exact kinematics, rendered features where our projection
puts them, velocity tracking with dynamics, the robot interface, the scenario wiring.

Small images (160x120) and few frames; the rendering tests skip, with the reason, only when
no offscreen OpenGL backend works here."""

from __future__ import annotations

import copy
import os
from typing import Any

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco's import, as redservo.physics does
pytest.importorskip("mujoco", reason="the MuJoCo backend needs redservo[mujoco]")

from redservo.camera import Camera
from redservo.errors import ConfigurationError, ScenarioError
from redservo.experiment.build import build
from redservo.features import PointFeature
from redservo.physics import MujocoActuator, MujocoArm, MujocoCamera, MujocoRobot
from redservo.physics._mj import rendering_available
from redservo.robots import Afma6, Panda, make_robot
from redservo.scenario import load_scenario, parse_scenario
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

SMALL = Camera(px=150.0, py=150.0, u0=80.0, v0=60.0, width=160, height=120)


def _needs_rendering() -> None:
    why = rendering_available()
    if why is not None:
        pytest.skip(why)


@pytest.mark.parametrize("name", ["panda", "afma6", "humanoid9"])
def test_camera_pose_agrees_with_our_kinematics(name: str) -> None:
    robot = make_robot(name)
    arm = MujocoArm(robot)
    rng = np.random.default_rng(3)
    for _ in range(25):
        q = rng.uniform(robot.q_min, robot.q_max)
        arm.set_q(q)
        np.testing.assert_allclose(arm.q, q, atol=1e-12)
        assert np.abs(arm.camera_pose() - robot.fkine(q)).max() <= 1e-9


def test_urdf_robot_kinematics_agree() -> None:
    pytest.importorskip("pinocchio", reason="URDF robots need redservo[urdf]")
    from redservo.robots import URDFRobot
    from redservo.robots.urdf import shipped_urdf

    robot = URDFRobot(shipped_urdf("ur5e"), camera_link="camera_link")
    arm = MujocoArm(robot)
    q = np.random.default_rng(4).uniform(robot.q_min, robot.q_max)
    arm.set_q(q)
    assert np.abs(arm.camera_pose() - robot.fkine(q)).max() <= 1e-9


def test_velocity_servo_tracks_with_lag_and_holds_against_gravity() -> None:
    robot = Panda()
    q0 = robot.ready_configuration()
    arm = MujocoArm(robot, q_ref=q0, tracking_time=0.02)
    arm.set_q(q0)
    arm.step(np.zeros(7), 0.5)  # gravity compensated: at rest, it stays
    assert np.abs(arm.q - q0).max() < 1e-6
    cmd = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5])
    arm.step(cmd, 0.02)  # one time constant of joint 6: about 63 % of the step
    assert 0.4 * 0.5 < arm.qdot[6] < 0.8 * 0.5
    arm.step(cmd, 0.2)
    assert abs(arm.qdot[6] - 0.5) < 0.01
    assert 0.45 < arm.tracking.peak[6] <= 0.5  # after the first 1 ms step: nearly all of it
    assert arm.tracking.steps == 500 + 20 + 200  # 1 ms steps since set_q


def test_afma6_coupled_wrist_follows_our_joint_velocities() -> None:
    robot = Afma6()
    q0 = (robot.q_min + robot.q_max) / 2
    arm = MujocoArm(robot, q_ref=q0)
    arm.set_q(q0)
    cmd = np.array([0.0, 0.0, 0.0, 0.0, 0.2, 0.0])  # B alone: C' moves by -g B in MuJoCo
    arm.step(cmd, 0.3)
    assert abs(arm.qdot[4] - 0.2) < 0.01 and abs(arm.qdot[5]) < 1e-3


def _dots_scene(robot: Any, q: np.ndarray, depth: float) -> Scene:
    pts = np.array([[-0.03, -0.02, 0.0], [0.03, -0.02, 0.0], [0.03, 0.025, 0.0], [-0.02, 0.02, 0]])
    cMo = make_transform(t=(0.01, -0.005, depth), rotvec=(0.25, -0.2, 0.4))
    wMo = robot.fkine(q) @ cMo
    return Scene([PointSet("target", pts, trajectory=Static(wMo))])


def test_rendered_dots_agree_with_our_projection() -> None:
    _needs_rendering()
    robot = Panda()
    q = robot.ready_configuration()
    scene = _dots_scene(robot, q, 0.3)
    arm = MujocoArm(robot, scene, camera=SMALL, q_ref=q)
    arm.set_q(q)
    pts = scene.object("target").points
    task = VisualTask([TaskTerm(PointFeature(p), "target") for p in pts], s_star=np.zeros(8))
    cam = MujocoCamera(arm, depth="true")
    bMc = robot.fkine(q)
    reading = cam.read(task, scene, bMc, 0.0)
    assert reading.s is not None and reading.lost == ()
    truth, _ = task.measure(scene, bMc, 0.0)
    err_px = np.abs((reading.s - truth).reshape(-1, 2)) * [SMALL.px, SMALL.py]
    assert err_px.max() <= 0.5, err_px
    image = np.asarray(reading.image)
    assert image.shape == (120, 160) and image.min() < 40 and image.max() > 150  # ink, paper


def test_rendered_tag_corners_agree_with_our_projection() -> None:
    pytest.importorskip("cv2", reason="tags are decoded by OpenCV (redservo[vision])")
    _needs_rendering()
    from redservo.scene import Tag

    robot = Panda()
    q = robot.ready_configuration()
    cMo = make_transform(t=(0.01, -0.01, 0.3), rotvec=(np.pi - 0.2, 0.15, 0.3))  # printed side
    tag = Tag("tag", size=0.08, tag_id=7, trajectory=Static(robot.fkine(q) @ cMo))
    scene = Scene([tag])
    camera = Camera(px=300.0, py=300.0, u0=160.0, v0=120.0, width=320, height=240)
    arm = MujocoArm(robot, scene, camera=camera, q_ref=q)
    task = VisualTask([TaskTerm(PointFeature(p), "tag") for p in tag.points], s_star=np.zeros(8))
    reading = MujocoCamera(arm, depth="true").read(task, scene, robot.fkine(q), 0.0)
    assert reading.s is not None and reading.lost == (), reading.reason
    truth, _ = task.measure(scene, robot.fkine(q), 0.0)
    assert np.abs(reading.s - truth).max() * 300.0 <= 0.5  # px, each corner in its own order


def test_camera_refuses_a_pose_that_is_not_its_arms() -> None:
    _needs_rendering()
    robot = Panda()
    q = robot.ready_configuration()
    scene = _dots_scene(robot, q, 0.3)
    arm = MujocoArm(robot, scene, camera=SMALL)  # at rest in the middle of its limits
    task = VisualTask([TaskTerm(PointFeature(scene.object("target").points[0]), "target")], [0, 0])
    cam = MujocoCamera(arm, depth="true")
    with pytest.raises(ConfigurationError, match="current state"):
        cam.read(task, scene, robot.fkine(q), 0.0)  # the arm is not at q


def test_mujoco_robot_in_the_servo_loop_on_a_virtual_clock() -> None:
    from redservo import make_law
    from redservo.hardware import IdealFeatureSource, ServoLoop, VirtualClock

    robot = Panda()
    q0 = robot.ready_configuration()
    scene = _dots_scene(robot, q0, 0.4)
    pts = scene.object("target").points
    task = VisualTask(
        [TaskTerm(PointFeature(p), "target") for p in pts],
        s_star=(pts[:, :2] / 0.35).ravel(),
    )
    clock = VirtualClock()
    arm = MujocoArm(robot, q_ref=q0)
    bot = MujocoRobot(arm, q0, clock, period=0.04)
    source = IdealFeatureSource(task, scene, bot)  # type: ignore[arg-type]
    loop = ServoLoop(
        bot,
        source,
        robot,
        task,
        make_law("iterative-smooth"),
        robot.limits(),
        period=0.04,
        lam=0.5,
        max_iterations=40,
        clock=clock,
        sleep=clock.sleep,
    )
    res = loop.run()
    errs = np.linalg.norm(res.log.e1, axis=1)
    assert errs[-1] < 0.5 * errs[0]
    assert bot.stops == 1 and bot.commands >= 30
    t, q = bot.read_joints()
    assert t == pytest.approx(clock(), abs=0.04) and np.all(np.isfinite(q))


def test_robot_period_must_be_whole_physics_steps() -> None:
    arm = MujocoArm(Panda())
    with pytest.raises(ConfigurationError, match="multiple of the physics step"):
        MujocoRobot(arm, Panda().ready_configuration(), period=0.0405)


def test_scenario_runs_through_mujoco_images_and_refuses_actuators() -> None:
    _needs_rendering()
    sc = load_scenario("panda-mujoco-4points")
    data = sc.data
    data["simulation"]["max_iterations"] = 6
    data["camera"] = {"px": 150.0, "py": 150.0, "u0": 80.0, "v0": 60.0, "width": 160, "height": 120}
    exp = build(parse_scenario(data, "small.toml"))
    assert isinstance(exp.actuator, MujocoActuator) and isinstance(exp.sensor, MujocoCamera)
    res = exp.run()
    assert res.outcome == "max_iterations" and len(res.log) == 6
    assert exp.actuator.arm.tracking.steps == 6 * 40  # dt / timestep physics steps per period
    bad = copy.deepcopy(data)
    bad["actuators"] = {"tau": 0.05}
    with pytest.raises(ScenarioError, match="actuators"):
        build(parse_scenario(bad, "bad.toml"))


def test_scenario_with_the_ideal_sensor_and_its_refusals() -> None:
    base = load_scenario("panda-mujoco-4points").data
    data = copy.deepcopy(base)
    data["simulator"]["camera"] = "ideal"
    exp = build(parse_scenario(data, "ideal.toml"))
    assert isinstance(exp.actuator, MujocoActuator) and exp.sensor is None
    res = exp.run(max_iterations=3)
    assert len(res.log) == 3
    arm = exp.actuator.arm
    np.testing.assert_array_equal(res.log.q[0], exp.q0)  # the arm starts at the run's q0
    assert np.abs(arm.q - exp.q0).max() > 1e-4 and arm.tracking.steps == 3 * 40
    bad = copy.deepcopy(data)
    bad["simulator"]["timestep"] = 0.003  # does not divide dt = 0.04 s
    with pytest.raises(ScenarioError, match=r"simulator\.timestep"):
        build(parse_scenario(bad, "bad.toml"))


def test_a_rendered_scenario_without_an_offscreen_backend_is_one_clear_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import redservo.physics._mj as mj

    monkeypatch.setattr(mj, "_RENDER_OK", ["MuJoCo cannot render offscreen (test)"])
    with pytest.raises(ScenarioError, match=r"simulator\.camera.*libegl1.*camera = 'ideal'"):
        build(load_scenario("panda-mujoco-4points"))


@pytest.mark.parametrize(
    ("timestep", "dt", "message"),
    [
        (1e-12, 0.04, r"simulator\.timestep.*>= 1e-05"),  # was accepted: 4e10 steps a period
        (2e-5, 1.0, r"simulator\.timestep.*at most 10000 physics steps per control period"),
    ],
)
def test_a_tiny_physics_step_is_one_scenario_error(
    timestep: float, dt: float, message: str
) -> None:
    data = copy.deepcopy(load_scenario("panda-mujoco-4points").data)
    data["simulator"].update(camera="ideal", timestep=timestep)
    data["control"]["dt"] = dt
    with pytest.raises(ScenarioError, match=message):
        build(parse_scenario(data, "tiny.toml"))
    with pytest.raises(ConfigurationError, match=r"timestep must be in \[1e-05, 1\] s"):
        MujocoArm(Panda(), timestep=1e-12)
