"""The distance shield on the true geometry (control.avoidance.exact_scale): a command that
swings a link past an obstacle by centimetres a period never lands a pair under d_safe,
whatever the curvature of the distance; and a start inside d_safe is refused."""

from __future__ import annotations

import tomllib
from importlib import resources

import numpy as np
import pytest

from redservo.collision import Obstacle, Shape
from redservo.control.avoidance import Collision, shield_command
from redservo.errors import ScenarioError
from redservo.experiment.build import build
from redservo.redundancy.base import Diagnostics
from redservo.robots import make_robot
from redservo.scenario import parse_scenario
from redservo.scene import Static
from redservo.spatial import make_transform


def test_shielded_commands_keep_d_safe_on_the_true_geometry() -> None:
    robot = make_robot("panda")
    lim = robot.limits()
    rng = np.random.default_rng(7)
    dt, d_safe, checked = 0.04, 0.02, 0
    for _ in range(80):
        q = lim.q_min + (lim.q_max - lim.q_min) * rng.uniform(0.2, 0.8, robot.n)
        O = np.stack([M[:3, 3] for M in robot.link_poses(q, check_limits=False).values()])
        u = rng.normal(size=3)
        centre = O[rng.integers(2, O.shape[0])] + u / np.linalg.norm(u) * rng.uniform(0.14, 0.2)
        ball = Obstacle("ball", Shape("sphere", radius=0.05), Static(make_transform(t=centre)))
        coll = Collision((ball,), d_safe=d_safe)
        pd = coll.measure(robot, q, 0.0)
        if np.min(pd.d) < d_safe:
            continue  # a start inside d_safe is refused by the scenario checks
        qdot = rng.normal(size=robot.n) * 2.5  # rad/s: up to ~10 cm a period at the tip
        cmd, _ = shield_command(coll, robot, qdot, Diagnostics("t"), q, 0.0, dt, None, None)
        after = Collision((ball,), d_safe=d_safe).measure(robot, q + dt * cmd, dt)
        assert float(np.min(after.d)) >= d_safe
        checked += 1
    assert checked >= 20


def test_a_start_inside_d_safe_is_refused_naming_the_obstacle() -> None:
    text = resources.files("redservo.scenarios").joinpath("panda-post.toml").read_text()
    data = tomllib.loads(text)
    exp = build(parse_scenario(data, "post.toml"))
    pd = exp.options.collision.measure(exp.robot, exp.q0, 0.0)  # type: ignore[union-attr]
    d0 = float(np.min(pd.d))
    data["collision"]["d_safe"] = d0 + 0.005
    data["collision"]["d_influence"] = d0 + 0.05
    with pytest.raises(ScenarioError, match=r"obstacles\[0\].*within collision\.d_safe"):
        build(parse_scenario(data, "post.toml"))
