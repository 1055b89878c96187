"""The compiled primitive-pair distances (redservo.kernels.collide) against coal on random
pairs: the same signed distance to 1e-9 m and the same witness points."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.collision import Shape
from redservo.collision.pair import _query, _transform
from redservo.collision.query import _capsule_frame
from redservo.kernels import lazy
from redservo.spatial import make_transform

_K = lazy("collide")


def _capsule(rng: np.random.Generator, length_min: float = 0.02) -> tuple:
    a0 = rng.uniform(-0.3, 0.3, 3)
    u = rng.normal(size=3)
    a1 = a0 + rng.uniform(length_min, 0.4) * u / np.linalg.norm(u)
    return a0, a1, float(rng.uniform(0.01, 0.1))


def _coal_capsule(a0: np.ndarray, a1: np.ndarray, r: float) -> tuple[Any, Any]:
    if np.linalg.norm(a1 - a0) == 0.0:
        return Shape("sphere", radius=r).coal(), _transform(make_transform(t=a0))
    shape = Shape("capsule", radius=r, length=float(np.linalg.norm(a1 - a0)))
    return shape.coal(), _transform(_capsule_frame(a0, a1))


def _check(ours: tuple, ref: tuple, witness: bool = True) -> None:
    d, wa, wb = ours
    dc, ca, cb = ref
    assert d == pytest.approx(dc, abs=1e-9)
    if witness:
        np.testing.assert_allclose(wa, ca, atol=1e-7)
        np.testing.assert_allclose(wb, cb, atol=1e-7)


@pytest.mark.parametrize("sphere", [False, True])
def test_capsule_capsule_matches_coal(sphere: bool) -> None:
    rng = np.random.default_rng(1)
    for _ in range(300):
        a0, a1, ra = _capsule(rng)
        b0, b1, rb = _capsule(rng)
        if sphere:
            b1 = b0.copy()
        ref = _query(*_coal_capsule(a0, a1, ra), *_coal_capsule(b0, b1, rb))
        _check(_K.capsule_capsule(a0, a1, ra, b0, b1, rb), ref, witness=ref[0] > 1e-6)


def test_capsule_plane_matches_coal() -> None:
    rng = np.random.default_rng(2)
    for _ in range(300):
        a0, a1, r = _capsule(rng)
        M = make_transform(t=rng.uniform(-0.3, 0.3, 3), rotvec=rng.normal(size=3) * 0.5)
        ref = _query(*_coal_capsule(a0, a1, r), Shape("plane").coal(), _transform(M))
        ours = _K.capsule_plane(a0, a1, r, M[:3, 3].copy(), M[:3, 2].copy())
        # a segment parallel to the plane has no unique witness: compare the distance
        parallel = abs(np.dot(a1 - a0, M[:3, 2])) < 1e-6
        _check(ours, ref, witness=ref[0] > 0 and not parallel)


def test_capsule_box_matches_coal() -> None:
    rng = np.random.default_rng(3)
    checked = 0
    for _ in range(300):
        a0, a1, r = _capsule(rng)
        size = rng.uniform(0.05, 0.4, 3)
        M = make_transform(t=rng.uniform(-0.3, 0.3, 3), rotvec=rng.normal(size=3))
        ref = _query(
            *_coal_capsule(a0, a1, r), Shape("box", size=tuple(size)).coal(), _transform(M)
        )
        if ref[0] <= 1e-6:
            continue  # coal's EPA depth is approximate; separated pairs only
        _check(_K.capsule_box(a0, a1, r, M, 0.5 * size), ref, witness=False)
        checked += 1
    assert checked > 100


def test_capsule_inside_a_box_by_hand() -> None:
    M = np.eye(4)
    d, _wa, wb = _K.capsule_box(
        np.array([0.0, 0.0, -0.1]), np.array([0.0, 0.0, 0.1]), 0.05, M, np.array([0.3, 0.2, 0.5])
    )
    assert d == pytest.approx(-0.25)  # the nearest face is y = ±0.2: depth 0.2 + radius
    assert abs(wb[1]) == pytest.approx(0.2)


def test_capsule_cylinder_matches_coal() -> None:
    """The compiled capsule/cylinder pair (the panda-posts post) against coal."""
    rng = np.random.default_rng(4)
    checked = 0
    for _ in range(300):
        a0, a1, r = _capsule(rng)
        radius, length = float(rng.uniform(0.02, 0.2)), float(rng.uniform(0.05, 0.6))
        M = make_transform(t=rng.uniform(-0.3, 0.3, 3), rotvec=rng.normal(size=3))
        shape = Shape("cylinder", radius=radius, length=length)
        ref = _query(*_coal_capsule(a0, a1, r), shape.coal(), _transform(M))
        if ref[0] <= 1e-6:
            continue  # coal's EPA depth is approximate; separated pairs only
        ours = _K.capsule_cylinder(a0, a1, r, M, np.array([radius, length, 0.0]))
        _check(ours, ref, witness=False)
        # coal's GJK on a cylinder stops on a flat optimum: the distances agree to 1e-10 m,
        # the witnesses to 1e-5 m only
        np.testing.assert_allclose(ours[1], ref[1], atol=1e-5)
        np.testing.assert_allclose(ours[2], ref[2], atol=1e-5)
        checked += 1
    assert checked > 100


def test_capsule_inside_a_cylinder_by_hand() -> None:
    size = np.array([0.1, 1.0, 0.0])  # radius 0.1 m, 1 m long along z
    seg = (np.array([0.02, 0.0, -0.1]), np.array([0.02, 0.0, 0.1]))
    d, _wa, wb = _K.capsule_cylinder(*seg, 0.03, np.eye(4), size)
    assert d == pytest.approx(-0.11)  # 8 cm inside the side, plus the radius
    np.testing.assert_allclose(wb[:2], [0.1, 0.0], atol=1e-12)
    d, _wa, wb = _K.capsule_cylinder(
        np.array([0.0, 0.0, 0.6]), np.array([0.0, 0.0, 0.8]), 0.05, np.eye(4), size
    )
    assert d == pytest.approx(0.05)  # above the top cap
    np.testing.assert_allclose(wb, [0.0, 0.0, 0.5], atol=1e-12)


@pytest.mark.parametrize("self_collision", [False, True])
def test_collision_measures_with_the_kernels_as_coal_does(self_collision: bool) -> None:
    """Collision.measure on a DH robot among static primitives uses the compiled pairs
    (kernels/loop_collide.py, shared with the campaign loop): the same distances as coal's
    records, their Jacobians against finite differences."""
    from redservo.collision import Obstacle, distances
    from redservo.control.avoidance import Collision
    from redservo.robots import make_robot
    from redservo.scene import Static

    robot = make_robot("panda")
    obs = [
        Obstacle(
            "post",
            Shape("cylinder", radius=0.03, length=1.0),
            Static(make_transform(t=(0.45, 0, 0.5))),
        ),
        Obstacle("ball", Shape("sphere", radius=0.08), Static(make_transform(t=(0.3, 0.35, 0.5)))),
        Obstacle(
            "bar",
            Shape("capsule", radius=0.02, length=0.5),
            Static(make_transform(t=(0.3, -0.2, 0.3))),
        ),
        Obstacle(
            "crate", Shape("box", size=(0.2, 0.1, 0.3)), Static(make_transform(t=(-0.3, 0.3, 0.2)))
        ),
        Obstacle("floor", Shape("plane"), Static(make_transform(t=(0, 0, -0.05)))),
    ]
    c = Collision(tuple(obs), self_collision=self_collision)
    assert c.compiled(robot) is not None
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = rng.uniform(robot.q_min, robot.q_max)
        pd = c.measure(robot, q, 0.0)
        recs = distances(robot, q, obs, self_collision=self_collision)
        assert pd.names == tuple(f"{r.first}/{r.second}" for r in recs)
        assert pd.kinds == tuple(r.kind for r in recs)
        ref = np.array([r.distance for r in recs])
        sep = ref > 1e-6  # coal's EPA depth is approximate
        np.testing.assert_allclose(pd.d[sep], ref[sep], atol=1e-8)
        h = 1e-7
        for j in range(robot.n):
            dq = np.zeros(robot.n)
            dq[j] = h
            fd = (c.measure(robot, q + dq, 0.0).d - c.measure(robot, q - dq, 0.0).d) / (2 * h)
            np.testing.assert_allclose(pd.J[sep, j], fd[sep], atol=2e-5)
