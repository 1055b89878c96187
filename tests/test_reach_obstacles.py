"""Reachability among obstacles (redservo.campaign.reach_obstacles): a goal met only with a
link within d_safe of an obstacle is not reachable."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from redservo.campaign import draw_sample, load_campaign, reach
from redservo.campaign.reach import desired_camera_pose, reachable
from redservo.collision import Obstacle, Shape
from redservo.control.avoidance import Collision
from redservo.experiment.build import build
from redservo.kernels import reach as reach_kernels
from redservo.scene import Static
from redservo.spatial import inverse, make_transform


def _with(exp: Any, shape: Shape, centre: Any, d_safe: float = 0.02) -> Any:
    """``exp`` with one obstacle (attached after the build: the sample's start is a few cm
    from its goal, and a start in collision is a scenario error)."""
    ob = Obstacle("ob", shape, Static(make_transform(t=centre)))
    exp.options = replace(exp.options, collision=Collision((ob,), d_safe=d_safe))
    return exp


def test_a_goal_met_only_in_collision_is_not_reachable(monkeypatch: pytest.MonkeyPatch) -> None:
    """A ball far away leaves the sample reachable; a floor above the whole arm (every
    configuration in collision) makes it unreachable; a ball at the goal's flange (every
    configuration at the desired camera pose puts the flange there) leaves no clear pose
    solution, and within d_safe of the flange neither."""
    exp = build(draw_sample(load_campaign("panda-near-limits"), 0, 0).scenario)
    assert reachable(exp) is True
    assert reachable(_with(exp, Shape("sphere", radius=0.01), (3.0, 3.0, 3.0))) is True
    assert reachable(_with(exp, Shape("plane"), (0.0, 0.0, 5.0))) is False
    bMc = desired_camera_pose(exp)
    assert bMc is not None
    flange = (bMc @ inverse(exp.robot.eMc))[:3, 3]
    # The pose stage alone: the feature stage may meet e1 = C (s - s*) ≈ 0 at another pose.
    monkeypatch.setattr(reach, "feature_solution", lambda *a: None)
    monkeypatch.setattr(reach_kernels, "feature_solution", lambda *a: (False, a[3]))  # compiled
    assert reachable(_with(exp, Shape("sphere", radius=0.01), flange)) is False
    # 6 cm above the flange: at most 1 cm from the ee capsule (radius 4 cm), inside d_safe
    above = flange + np.array([0.0, 0.0, 0.06])
    assert reachable(_with(exp, Shape("sphere", radius=0.01), above)) is False
    assert reachable(_with(exp, Shape("sphere", radius=0.01), (3.0, 3.0, 3.0))) is True
