"""Collision geometry and distances (issue 30 items 1-2): obstacles in scenarios, the
built-in robots' capsules, distances and Jacobians against finite differences, self pairs."""

from __future__ import annotations

import itertools
import re
import tomllib
from importlib import resources
from typing import Any

import numpy as np
import pytest

from redservo.collision import Obstacle, Shape, distances, link_capsules, self_pairs
from redservo.errors import GeometryError, ScenarioError, UnknownNameError
from redservo.experiment.build import build
from redservo.robots import make_robot
from redservo.scenario import parse_scenario
from redservo.scene import ConstantVelocity, Static
from redservo.spatial import make_transform


def _panda_data() -> dict[str, Any]:
    text = resources.files("redservo.scenarios").joinpath("panda-4points.toml").read_text()
    return tomllib.loads(text)


def _obstacles() -> list[Obstacle]:
    M = make_transform
    return [
        Obstacle("ball", Shape("sphere", radius=0.05), Static(M(t=(0.4, 0.2, 0.5)))),
        Obstacle(
            "crate",
            Shape("box", size=(0.1, 0.2, 0.3)),
            Static(M(t=(0.3, -0.3, 0.4), rotvec=(0.3, 0.2, 0.1))),
        ),
        Obstacle(
            "bar",
            Shape("capsule", radius=0.03, length=0.5),
            Static(M(t=(-0.2, 0.3, 0.6), rotvec=(1.0, 0.0, 0.0))),
        ),
        Obstacle("post", Shape("cylinder", radius=0.02, length=1.0), Static(M(t=(0.5, 0, 0.5)))),
        Obstacle("floor", Shape("plane"), Static(M(t=(0.0, 0.0, -0.3)))),
    ]


# ----------------------------------------------------------------------------- scenario schema


def test_scenario_obstacles_build_into_the_experiment() -> None:
    data = _panda_data()
    data["obstacles"] = [
        {"name": "table", "shape": "plane", "pose": {"translation": [0.0, 0.0, -0.1]}},
        {
            "name": "post",
            "shape": "cylinder",
            "radius": 0.02,
            "length": 0.8,
            "pose": {"translation": [0.6, 0.3, 0.4], "rpy_deg": [0.0, 0.0, 10.0]},
            "motion": {"kind": "constant_velocity", "velocity": [0.0, -0.01, 0.0]},
        },
        {"name": "crate", "shape": "box", "size": [0.1, 0.2, 0.3]},
    ]
    data["obstacles"][2]["pose"] = {"translation": [-0.5, -0.5, 0.15]}
    exp = build(parse_scenario(data, "my.toml"))
    names = [o.name for o in exp.obstacles]
    assert names == ["table", "post", "crate"]
    post = exp.obstacles[1]
    assert post.shape == Shape("cylinder", radius=0.02, length=0.8)
    assert isinstance(post.trajectory, ConstantVelocity)
    np.testing.assert_allclose(post.pose(2.0)[:3, 3], [0.6, 0.28, 0.4])
    assert exp.obstacles[2].shape.size == (0.1, 0.2, 0.3)


@pytest.mark.parametrize(
    ("obstacle", "key", "message"),
    [
        ({"shape": "cone", "radius": 0.1}, "obstacles[0].shape", "unknown shape 'cone'"),
        ({"shape": "sphere", "radius": 0.0}, "obstacles[0].radius", "must be > 0"),
        ({"shape": "sphere", "radius": -0.1}, "obstacles[0].radius", "must be > 0"),
        ({"shape": "box", "size": [0.1, 0.0, 0.1]}, "obstacles[0].size", "must be > 0"),
        ({"shape": "box"}, "obstacles[0].size", "a box needs size"),
        ({"shape": "capsule", "radius": 0.1}, "obstacles[0].length", "needs length"),
        ({"shape": "sphere", "radius": 0.1, "length": 1.0}, "obstacles[0].length", "takes no"),
        (
            {"shape": "cylinder", "radius": 0.1, "length": -1.0},
            "obstacles[0].length",
            "must be > 0",
        ),
    ],
)
def test_bad_obstacles_name_the_key(obstacle: dict[str, Any], key: str, message: str) -> None:
    data = _panda_data()
    data["obstacles"] = [{"name": "bad", **obstacle}]
    with pytest.raises(ScenarioError, match=re.escape(f"key '{key}'")):
        parse_scenario(data, "my.toml")
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(data, "my.toml")


def test_duplicate_obstacle_names_are_refused() -> None:
    data = _panda_data()
    data["obstacles"] = [{"name": "a", "shape": "plane"}, {"name": "a", "shape": "plane"}]
    with pytest.raises(ScenarioError, match=r"obstacles\[1\]\.name.*duplicate obstacle"):
        parse_scenario(data, "my.toml")


def test_start_in_collision_names_the_pair() -> None:
    data = _panda_data()
    data["obstacles"] = [
        {"name": "far", "shape": "sphere", "radius": 0.05, "pose": {"translation": [2, 2, 2]}},
        {"name": "blob", "shape": "sphere", "radius": 0.1, "pose": {"translation": [0, 0, 0.2]}},
    ]
    with pytest.raises(ScenarioError, match=r"key 'obstacles\[1\]'.*'panda_joint1'.*'blob'"):
        build(parse_scenario(data, "my.toml"))


def test_shape_checks_its_sizes() -> None:
    with pytest.raises(GeometryError, match="unknown shape 'cone'"):
        Shape("cone")
    with pytest.raises(GeometryError, match="radius"):
        Shape("capsule", radius=-1.0, length=1.0)
    with pytest.raises(GeometryError, match="size"):
        Shape("box", size=(1.0, float("nan"), 1.0))


# ----------------------------------------------------------------------------- distances


def _fd_jacobian(robot: Any, q: np.ndarray, obstacles: list[Obstacle], k: int) -> np.ndarray:
    h = 1e-5
    g = np.zeros(robot.n)
    for j in range(robot.n):
        dq = np.zeros(robot.n)
        dq[j] = h
        plus = distances(robot, q + dq, obstacles, self_collision=True)[k].distance
        minus = distances(robot, q - dq, obstacles, self_collision=True)[k].distance
        g[j] = (plus - minus) / (2 * h)
    return g


@pytest.mark.parametrize("name", ["panda", "humanoid9", "afma6"])
def test_distance_jacobians_match_finite_differences(name: str) -> None:
    robot = make_robot(name)
    rng = np.random.default_rng(30)
    obstacles = _obstacles()
    checked = 0
    for _ in range(6):
        q = robot.q_min + (robot.q_max - robot.q_min) * rng.random(robot.n)
        records = distances(robot, q, obstacles, self_collision=True)
        for k, rec in enumerate(records):
            assert np.isfinite(rec.distance) and rec.jacobian.shape == (robot.n,)
            assert abs(np.linalg.norm(rec.normal) - 1.0) < 1e-9
            if abs(rec.distance) < 1e-3 or rng.random() > 0.3:
                continue  # at contact the distance is not differentiable; sample the rest
            # coal's GJK on a cylinder (flat faces) is exact to ~1e-10 m only: FD noise
            atol = 2e-5 if rec.second == "post" else 1e-6
            np.testing.assert_allclose(
                rec.jacobian, _fd_jacobian(robot, q, obstacles, k), atol=atol
            )
            checked += 1
    assert checked >= 10


def test_witness_points_are_consistent_with_the_distance() -> None:
    robot = make_robot("panda")
    q = robot.ready_configuration()  # type: ignore[attr-defined]
    for rec in distances(robot, q, _obstacles()):
        if rec.distance > 0:
            assert np.linalg.norm(rec.a - rec.b) == pytest.approx(rec.distance, abs=1e-9)
            np.testing.assert_allclose(rec.a - rec.b, rec.distance * rec.normal, atol=1e-9)


def test_capsule_against_a_sphere_by_hand() -> None:
    robot = make_robot("panda")
    q = np.zeros(7)
    base = link_capsules(robot)[0]  # panda_joint1: z from 0 to 0.333 m
    ball = Obstacle("ball", Shape("sphere", radius=0.1), Static(make_transform(t=(0.5, 0, 0.2))))
    rec = distances(robot, q, [ball], capsules=[base])[0]
    assert rec.distance == pytest.approx(0.5 - 0.1 - base.radius, abs=1e-9)
    np.testing.assert_allclose(rec.jacobian, 0.0, atol=1e-12)  # joint 1 spins it in place


def test_moving_obstacle_is_posed_at_t() -> None:
    robot = make_robot("panda")
    q = np.zeros(7)
    cap = link_capsules(robot)[:1]
    ball = Obstacle(
        "ball",
        Shape("sphere", radius=0.1),
        ConstantVelocity(make_transform(t=(0.5, 0, 0.2)), np.array([-0.1, 0, 0]), np.zeros(3)),
    )
    d0 = distances(robot, q, [ball], capsules=cap)[0].distance
    d1 = distances(robot, q, [ball], t=1.0, capsules=cap)[0].distance
    assert d0 - d1 == pytest.approx(0.1, abs=1e-9)


# ----------------------------------------------------------------------------- self pairs


def test_panda_self_pairs_exclude_neighbours_and_bridged_wrist() -> None:
    caps = link_capsules(make_robot("panda"))
    names = [c.name for c in caps]
    assert names == [
        "panda_joint1",
        "panda_joint3",
        "panda_joint4",
        "panda_joint5",
        "panda_joint7",
        "ee",
    ]
    pairs = self_pairs(caps)
    assert pairs == [
        ("panda_joint1", "panda_joint4"),
        ("panda_joint1", "panda_joint5"),
        ("panda_joint1", "panda_joint7"),
        ("panda_joint1", "ee"),
        ("panda_joint3", "panda_joint7"),
        ("panda_joint3", "ee"),
        ("panda_joint4", "panda_joint7"),
        ("panda_joint4", "ee"),
    ]
    # the excluded ones: neighbours, and links 3/5 and 5/flange across a link shorter
    # than the sum of their radii
    for a, b in itertools.pairwise(names):
        assert (a, b) not in pairs
    assert ("panda_joint3", "panda_joint5") not in pairs
    assert ("panda_joint5", "ee") not in pairs
    fewer = self_pairs(caps, exclude=[("ee", "panda_joint1")])
    assert ("panda_joint1", "ee") not in fewer and len(fewer) == len(pairs) - 1
    with pytest.raises(UnknownNameError, match="unknown link 'hand'"):
        self_pairs(caps, exclude=[("hand", "ee")])


def test_excluded_pairs_overlap_everywhere_and_kept_pairs_are_apart_at_ready() -> None:
    robot = make_robot("panda")
    q = robot.ready_configuration()  # type: ignore[attr-defined]
    records = distances(robot, q, self_collision=True)
    assert len(records) == 8 and all(r.kind == "self" and r.distance > 0 for r in records)


def test_robot_without_a_model_is_a_configuration_error() -> None:
    from redservo.errors import ConfigurationError
    from redservo.robots import shipped_urdf
    from redservo.robots.urdf import URDFRobot

    robot = URDFRobot(shipped_urdf("panda"), camera_link="panda_link8")
    with pytest.raises(ConfigurationError, match="no built-in collision model"):
        distances(robot, np.zeros(robot.n), _obstacles())


def test_obstacles_with_a_urdf_robot_warn_that_they_are_not_checked() -> None:
    pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio (redservo[urdf])")
    text = resources.files("redservo.scenarios").joinpath("panda-urdf-4points.toml").read_text()
    data = tomllib.loads(text)
    data["obstacles"] = [{"name": "table", "shape": "plane", "pose": {"translation": [0, 0, -1]}}]
    with pytest.warns(UserWarning, match="obstacles are not checked against the robot"):
        exp = build(parse_scenario(data, "urdf.toml"))
    assert [o.name for o in exp.obstacles] == ["table"]
