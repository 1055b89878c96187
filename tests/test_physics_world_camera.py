"""The MuJoCo backend with the camera fixed in the world (eye-to-hand, issue 23 item 2): the
carried targets move with the arm's physics exactly as our kinematics say, the rendered
features land where our projection puts them, and the closed loop converges.

Small images and few frames; the rendering tests skip, with the reason, only when no
offscreen OpenGL backend works here."""

from __future__ import annotations

import copy
import os
from typing import Any

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco's import, as redservo.physics does
pytest.importorskip("mujoco", reason="the MuJoCo backend needs redservo[mujoco]")

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.experiment.build import build
from redservo.features import PointFeature
from redservo.physics import MujocoActuator, MujocoArm, MujocoCamera, MujocoRobot
from redservo.physics._mj import rendering_available
from redservo.robots import Afma6, Panda
from redservo.robots.eye_to_hand import EyeToHandRobot
from redservo.scenario import load_scenario, parse_scenario
from redservo.scene import PointSet, Scene, Static, Tag
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

SCENARIO = "panda-mujoco-eye-to-hand"
Q0 = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])  # the scenario's start (rad)
WMC = make_transform(t=(0.95, 0.0, 0.55), rotvec=(-1.2092, -1.2092, 1.2092))  # its camera
EMO = make_transform(t=(0.0, -0.06, 0.01), rotvec=(0.331, -2.031, -1.553))  # its card
CAMERA = Camera(px=300.0, py=300.0, u0=160.0, v0=120.0, width=320, height=240)
SQUARE = np.array([[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0]])


def _needs_rendering() -> None:
    why = rendering_available()
    if why is not None:
        pytest.skip(why)


def _dots(eMo: np.ndarray = EMO, wMb: np.ndarray | None = None) -> Scene:
    """The card at ``eMo`` on the effector (the scene's world frame is the effector's, or
    ``wMb`` (4x4) maps it: ``eMo = inv(wMb) · wMo``)."""
    W = np.eye(4) if wMb is None else wMb
    return Scene([PointSet("target", SQUARE, trajectory=Static(W @ eMo))], wMb=W)


def _near_start(robot: Any, rng: np.random.Generator, k: int, spread: float) -> list[Any]:
    return [
        np.clip(Q0 + rng.uniform(-spread, spread, 7), robot.q_min, robot.q_max) for _ in range(k)
    ]


@pytest.mark.parametrize("carrier", [Panda(), Afma6()], ids=["panda", "afma6"])
def test_carried_object_and_camera_poses_agree_with_our_kinematics(carrier: Any) -> None:
    robot = EyeToHandRobot(carrier, WMC)
    arm = MujocoArm(robot, _dots(wMb=make_transform(t=(0.2, -0.1, 0.3), rotvec=(0.3, 0.2, -1))))
    assert arm.world_camera is not None and arm.drawn == ["target"]
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(20):
        q = rng.uniform(robot.q_min, robot.q_max)
        arm.set_q(q)
        bMo = carrier.fkine_ee(q) @ EMO  # the object the effector carries, our kinematics
        worst = max(worst, float(np.abs(arm.object_pose("target") - bMo).max()))
        worst = max(worst, float(np.abs(arm.camera_pose() - robot.fkine(q)).max()))
    assert worst <= 1e-9, worst
    # Moved by the physics, not set: after a motion the card is still where eMo puts it.
    arm.set_q((robot.q_min + robot.q_max) / 2)
    arm.step(np.full(robot.n, 0.2), 0.1)
    bMo = carrier.fkine_ee(arm.q) @ EMO
    assert np.abs(arm.object_pose("target") - bMo).max() <= 1e-9


def test_a_moving_object_cannot_be_carried() -> None:
    from redservo.scene import ConstantVelocity

    moving = Scene([PointSet("target", SQUARE, trajectory=ConstantVelocity(EMO, v=[0.01, 0, 0]))])
    with pytest.raises(ConfigurationError, match=r"'target' moves.*carried by the end effector"):
        MujocoArm(EyeToHandRobot(Panda(), WMC), moving)


def test_mujoco_robot_reports_the_eye_to_hand_camera_pose() -> None:
    robot = EyeToHandRobot(Panda(), WMC)
    bot = MujocoRobot(MujocoArm(robot, _dots()), Q0, period=0.04)
    assert np.abs(bot.true_pose() - robot.fkine(Q0)).max() <= 1e-9


def _measured_px(cam: MujocoCamera, task: VisualTask, scene: Scene, bMc: Any) -> float:
    cam.reset()
    reading = cam.read(task, scene, bMc, 0.0)
    assert reading.s is not None and reading.lost == (), reading.reason
    truth, _ = task.measure(scene, bMc, 0.0)
    return float(np.abs(reading.s - truth).max() * CAMERA.px)


def test_world_camera_renders_dots_where_our_projection_puts_them() -> None:
    _needs_rendering()
    robot = EyeToHandRobot(Panda(), WMC)
    scene = _dots()
    arm = MujocoArm(robot, scene, camera=CAMERA, q_ref=Q0)
    task = VisualTask([TaskTerm(PointFeature(p), "target") for p in SQUARE], s_star=np.zeros(8))
    cam = MujocoCamera(arm, depth="true")
    rng = np.random.default_rng(6)
    for q in _near_start(robot, rng, 3, 0.15):
        arm.set_q(q)
        assert _measured_px(cam, task, scene, robot.fkine(q)) <= 0.5
    image = np.asarray(cam.read(task, scene, robot.fkine(q), 0.0).image)
    assert image.min() < 40 and image.max() > 150  # ink, paper
    with pytest.raises(ConfigurationError, match="current state"):
        cam.read(task, scene, robot.fkine(Q0), 0.0)  # a camera pose of another arm state


def test_world_camera_renders_tag_corners_where_our_projection_puts_them() -> None:
    pytest.importorskip("cv2", reason="tags are decoded by OpenCV (redservo[vision])")
    _needs_rendering()
    robot = EyeToHandRobot(Panda(), WMC)
    # The tag 5 cm off the flange (the 1 cm of the dots card would put its white border
    # behind the arm's last link), printed side towards the camera.
    eMo = make_transform(t=(0.0, -0.06, 0.05), rotvec=(-1.075, 1.6977, -1.593))
    tag = Tag("tag", size=0.1, tag_id=7, trajectory=Static(eMo))
    scene = Scene([tag])
    arm = MujocoArm(robot, scene, camera=CAMERA, q_ref=Q0)
    task = VisualTask([TaskTerm(PointFeature(p), "tag") for p in tag.points], s_star=np.zeros(8))
    cam = MujocoCamera(arm, depth="true")
    for q in _near_start(robot, np.random.default_rng(7), 2, 0.1):
        arm.set_q(q)
        assert _measured_px(cam, task, scene, robot.fkine(q)) <= 0.5


def _small(data: dict[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(data)
    out["camera"].update(px=300.0, py=300.0, u0=160.0, v0=120.0, width=320, height=240)
    return out


def test_scenario_converges_with_mujoco_dynamics_and_the_ideal_sensor() -> None:
    data = copy.deepcopy(load_scenario(SCENARIO).data)
    data["simulator"]["camera"] = "ideal"
    exp = build(parse_scenario(data, "ideal.toml"))
    assert isinstance(exp.actuator, MujocoActuator) and exp.sensor is None
    assert exp.actuator.arm.world_camera is not None
    res = exp.run()
    assert res.outcome == "converged", res.outcome
    kinematic = copy.deepcopy(data)
    kinematic.pop("simulator")
    ref = build(parse_scenario(kinematic, "kin.toml")).run()
    assert ref.outcome == "converged" and abs(len(res.log) - len(ref.log)) <= 15


def test_scenario_through_the_world_cameras_images_makes_progress() -> None:
    _needs_rendering()
    exp = build(parse_scenario(_small(load_scenario(SCENARIO).data), "small.toml"))
    assert isinstance(exp.sensor, MujocoCamera) and exp.actuator is not None
    res = exp.run(max_iterations=25)
    assert res.outcome == "max_iterations" and len(res.log) == 25
    errs = np.linalg.norm(res.log.e1, axis=1)
    assert errs[-1] < 0.8 * errs[0], errs[[0, -1]]
    assert exp.actuator.arm.tracking.steps == 25 * 40


@pytest.mark.parametrize("mount", ["world", "hand"])
def test_a_distorted_off_centre_lens_renders_dots_where_our_model_puts_them(mount: str) -> None:
    """MuJoCo renders a pinhole: the lens is a warp of a wider render (physics.lens), and the
    principal point is off the image centre (MuJoCo's principalpixel reverses both axes)."""
    _needs_rendering()
    lens = Camera(300.0, 290.0, 170.0, 112.0, 320, 240, k1=-0.12, k2=0.05, p1=5e-4, p2=-4e-4)
    robot: Any = EyeToHandRobot(Panda(), WMC)
    scene = _dots()
    if mount == "hand":
        robot = Panda()
        cMo = make_transform(t=(0.02, -0.01, 0.5), rotvec=(0.2, -0.1, 0.3))
        scene = Scene([PointSet("target", SQUARE, trajectory=Static(robot.fkine(Q0) @ cMo))])
    arm = MujocoArm(robot, scene, camera=lens, q_ref=Q0)
    task = VisualTask([TaskTerm(PointFeature(p), "target") for p in SQUARE], s_star=np.zeros(8))
    cam = MujocoCamera(arm, depth="true")
    for q in _near_start(robot, np.random.default_rng(9), 2, 0.05):
        arm.set_q(q)
        assert _measured_px(cam, task, scene, robot.fkine(q)) <= 0.5


def test_the_sensor_distortion_becomes_the_rendered_lens() -> None:
    _needs_rendering()
    data = copy.deepcopy(load_scenario(SCENARIO).data)
    data["camera"].pop("distortion")
    data["sensor"]["distortion"] = [-0.1, 0.02]  # radial k1, k2 of an undistorted camera
    exp = build(parse_scenario(data, "k.toml"))
    assert isinstance(exp.sensor, MujocoCamera)
    assert exp.sensor.arm.camera.distortion == (-0.1, 0.02, 0.0, 0.0, 0.0)
    assert not exp.camera.distorted  # the scenario's camera is unchanged


def test_world_camera_measures_a_carried_sphere_where_our_projection_puts_it() -> None:
    _needs_rendering()
    from redservo.features import SphereFeature
    from redservo.scene import Sphere

    robot = EyeToHandRobot(Panda(), WMC)
    # A 4 cm ball held 8 cm beyond the flange, on its axis.
    scene = Scene([Sphere("ball", radius=0.04, trajectory=Static(make_transform(t=(0, 0, 0.08))))])
    arm = MujocoArm(robot, scene, camera=CAMERA, q_ref=Q0)
    task = VisualTask([TaskTerm(SphereFeature(0.04), "ball")], s_star=np.zeros(3))
    cam = MujocoCamera(arm, depth="true")
    for q in _near_start(robot, np.random.default_rng(8), 2, 0.1):
        arm.set_q(q)
        assert _measured_px(cam, task, scene, robot.fkine(q)) <= 0.5
