"""A URDF robot's own ``<collision>`` elements in the distances, the avoidance and the
records (redservo.collision.urdf_query): distances and Jacobians against finite
differences, the distance shield on them, and one error for an unreadable mesh."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from redservo.collision import Obstacle, Shape, distances
from redservo.control.avoidance import Collision, distance_shield
from redservo.errors import ConfigurationError, GeometryError
from redservo.robots import shipped_urdf
from redservo.scene import Static
from redservo.spatial import make_transform

pytest.importorskip("coal")
pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio (redservo[urdf])")

_CAPS = {
    "panda_link3": '<origin xyz="0 0 -0.05"/><geometry><cylinder radius="0.06" length="0.2"/>',
    "panda_link5": '<origin xyz="0 0.04 -0.12"/><geometry><box size="0.1 0.1 0.24"/>',
    "panda_link7": '<geometry><sphere radius="0.05"/>',
}


def _robot(tmp_path: Path, extra: str = "") -> object:
    from redservo.robots.urdf import URDFRobot

    text = shipped_urdf("panda").read_text()
    for link, body in _CAPS.items():
        col = f"<collision>{body}</geometry></collision>"
        text = re.sub(f'(<link name="{link}">)', rf"\1{col}", text)
    text = text.replace('<link name="panda_link8">', f'<link name="panda_link8">{extra}')
    path = tmp_path / "panda.urdf"
    path.write_text(text)
    return URDFRobot(path, camera_link="panda_link8")


_READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


def _ball(x: float = 0.45) -> Obstacle:
    return Obstacle("ball", Shape("sphere", radius=0.05), Static(make_transform(t=(x, 0.1, 0.5))))


def test_distances_and_jacobians_of_the_elements(tmp_path: Path) -> None:
    robot = _robot(tmp_path)
    q = _READY
    recs = distances(robot, q, [_ball()])  # type: ignore[arg-type]
    assert [r.first for r in recs] == list(_CAPS) and {r.kind for r in recs} == {"environment"}
    h = 1e-6

    def d(qq: np.ndarray, k: int) -> float:
        return distances(robot, qq, [_ball()])[k].distance  # type: ignore[arg-type]

    for k, rec in enumerate(recs):
        fd = [(d(q + h * e, k) - d(q - h * e, k)) / (2 * h) for e in np.eye(7)]
        np.testing.assert_allclose(rec.jacobian, fd, atol=1e-5)


def test_the_shield_keeps_d_safe_with_the_urdf_elements(tmp_path: Path) -> None:
    robot = _robot(tmp_path)
    coll = Collision((_ball(),), d_safe=0.02)
    coll.check_robot(robot)  # type: ignore[arg-type]
    q = _READY
    pd = coll.measure(robot, q, 0.0)  # type: ignore[arg-type]
    k = int(np.argmin(pd.d))
    toward = -pd.J[k] / (pd.J[k] @ pd.J[k]) * 2.0 * pd.d[k] / 0.04  # through it in a period
    s, pair = distance_shield(toward, pd.d, pd.J, dt=0.04, d_safe=0.02)
    assert pair >= 0 and s < 1.0
    assert pd.d[k] + 0.04 * s * pd.J[k] @ toward >= 0.02 - 1e-12


def test_a_urdf_without_elements_or_with_a_bad_mesh_is_one_error(tmp_path: Path) -> None:
    from redservo.robots.urdf import URDFRobot

    bare = URDFRobot(shipped_urdf("panda"), camera_link="panda_link8")
    with pytest.raises(ConfigurationError, match="no <collision> elements"):
        Collision((_ball(),)).check_robot(bare)
    bad = '<collision><geometry><mesh filename="../outside.stl"/></geometry></collision>'
    robot = _robot(tmp_path, bad)
    with pytest.raises(GeometryError, match=r"outside\.stl"):
        Collision((_ball(),)).check_robot(robot)  # type: ignore[arg-type]
    (tmp_path / "ok").mkdir()
    good = _robot(tmp_path / "ok")
    own = [r for r in distances(good, _READY, self_collision=True) if r.kind == "self"]  # type: ignore[arg-type]
    assert [(r.first, r.second) for r in own] == [
        ("panda_link3", "panda_link5"),
        ("panda_link3", "panda_link7"),
        ("panda_link5", "panda_link7"),
    ]  # tests/test_collision_urdf_self.py checks them
