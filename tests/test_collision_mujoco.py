"""Obstacles in the MuJoCo backend (geoms of the right size and pose), and coal's distances
against MuJoCo's ``mj_geomDistance`` on random primitive pairs (a second implementation)."""

from __future__ import annotations

import copy
import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
mujoco = pytest.importorskip("mujoco", reason="the MuJoCo backend needs redservo[mujoco]")

from redservo.collision import Obstacle, Shape  # noqa: E402
from redservo.collision.pair import _query, _transform  # noqa: E402
from redservo.experiment.build import build  # noqa: E402
from redservo.physics import MujocoActuator, MujocoArm  # noqa: E402
from redservo.physics.obstacles import obstacle_bodies, set_obstacle_poses  # noqa: E402
from redservo.robots import Panda  # noqa: E402
from redservo.scenario import load_scenario, parse_scenario  # noqa: E402
from redservo.scene import ConstantVelocity, Static  # noqa: E402
from redservo.spatial import make_transform  # noqa: E402

M = make_transform


def _quat_matrix(quat: np.ndarray) -> np.ndarray:
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, quat)
    return R.reshape(3, 3)


def test_arm_model_holds_each_obstacle_as_a_posed_native_geom() -> None:
    wMo = M(t=(0.4, -0.2, 0.3), rotvec=(0.2, -0.1, 0.5))
    obstacles = [
        Obstacle("ball", Shape("sphere", radius=0.05), Static(M(t=(0.5, 0.5, 0.5)))),
        Obstacle("crate", Shape("box", size=(0.1, 0.2, 0.3)), Static(wMo)),
        Obstacle("bar", Shape("capsule", radius=0.03, length=0.4), Static(wMo)),
        Obstacle("post", Shape("cylinder", radius=0.02, length=0.8), Static(wMo)),
        Obstacle("table", Shape("plane"), Static(M(t=(0, 0, -0.1)))),
    ]
    arm = MujocoArm(Panda(), obstacles=obstacles)
    m, d = arm.model, arm.data
    expect = {
        "ball": ("sphere", [0.05]),
        "crate": ("box", [0.05, 0.1, 0.15]),
        "bar": ("capsule", [0.03, 0.2]),
        "post": ("cylinder", [0.02, 0.4]),
        "table": ("plane", [0.0, 0.0]),
    }
    for name, (kind, size) in expect.items():
        g = m.geom(f"obs:{name}")
        assert int(g.type[0]) == int(getattr(mujoco.mjtGeom, f"mjGEOM_{kind.upper()}"))
        np.testing.assert_allclose(g.size[: len(size)], size)
    mujoco.mj_kinematics(m, d)
    body = d.body("obs:crate")
    np.testing.assert_allclose(body.xpos, wMo[:3, 3], atol=1e-12)
    np.testing.assert_allclose(body.xmat.reshape(3, 3), wMo[:3, :3], atol=1e-12)


def test_moving_obstacles_are_posed_at_t() -> None:
    moving = Obstacle(
        "ball",
        Shape("sphere", radius=0.05),
        ConstantVelocity(M(t=(0.5, 0.0, 0.5)), np.array([0.0, 0.1, 0.0]), np.zeros(3)),
    )
    arm = MujocoArm(Panda(), obstacles=[moving])
    set_obstacle_poses(arm.model, arm.data, [moving], 2.0)
    mujoco.mj_kinematics(arm.model, arm.data)
    np.testing.assert_allclose(arm.data.body("obs:ball").xpos, [0.5, 0.2, 0.5], atol=1e-12)


def test_scenario_obstacles_reach_the_mujoco_arm() -> None:
    data = copy.deepcopy(load_scenario("panda-mujoco-4points").data)
    data["simulator"]["camera"] = "ideal"
    data["obstacles"] = [
        {
            "name": "post",
            "shape": "cylinder",
            "radius": 0.02,
            "length": 0.5,
            "pose": {"translation": [0.7, 0.4, 0.25]},
        },
    ]
    exp = build(parse_scenario(data, "obstacles.toml"))
    assert isinstance(exp.actuator, MujocoActuator)
    assert exp.actuator.arm.model.geom("obs:post").size[1] == pytest.approx(0.25)


def _random_shape(rng: np.random.Generator, kinds: tuple[str, ...]) -> Shape:
    kind = str(rng.choice(kinds))
    r = float(rng.uniform(0.02, 0.2))
    if kind == "box":
        return Shape("box", size=tuple(rng.uniform(0.05, 0.4, 3)))
    if kind in ("capsule", "cylinder"):
        return Shape(kind, radius=r, length=float(rng.uniform(0.05, 0.5)))
    return Shape(kind, radius=r)


@pytest.mark.parametrize(
    ("kinds", "tol"),
    [
        (("sphere", "capsule"), 1e-9),  # both closed-form in MuJoCo and coal
        (("sphere", "capsule", "box"), 1e-6),  # MuJoCo's GJK for boxes: its own tolerance
    ],
)
def test_coal_agrees_with_mujoco_geom_distance(kinds: tuple[str, ...], tol: float) -> None:
    rng = np.random.default_rng(30)
    checked = 0
    for _ in range(60):
        s1, s2 = _random_shape(rng, kinds), _random_shape(rng, kinds)
        T1 = M(t=rng.uniform(-0.3, 0.3, 3), rotvec=rng.normal(size=3))
        T2 = M(t=rng.uniform(-0.3, 0.3, 3), rotvec=rng.normal(size=3))
        one, two = Obstacle("one", s1, Static(T1)), Obstacle("two", s2, Static(T2))
        xml = f"<mujoco><worldbody>{obstacle_bodies([one, two])}</worldbody></mujoco>"
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        fromto = np.zeros(6)
        dm = mujoco.mj_geomDistance(m, d, 0, 1, 10.0, fromto)
        dc, a, b = _query(s1.coal(), _transform(T1), s2.coal(), _transform(T2))
        if dc <= 1e-3:
            continue  # penetration depths: both are EPA estimates, compared elsewhere
        assert dc == pytest.approx(dm, abs=tol)
        np.testing.assert_allclose(a, fromto[:3], atol=max(tol, 1e-6) * 100)
        np.testing.assert_allclose(b, fromto[3:], atol=max(tol, 1e-6) * 100)
        checked += 1
    assert checked >= 20
