"""Tests of trajectories, scene objects and Scene.cMo (redservo.scene)."""

import numpy as np
import pytest

from redservo.errors import ConfigurationError, GeometryError, ShapeError, UnknownNameError
from redservo.scene import (
    ConstantVelocity,
    Cylinder,
    Line,
    PointSet,
    Scene,
    Sphere,
    Static,
    Waypoints,
)
from redservo.spatial import inverse, make_transform, matrix_to_rotvec


def _random_pose(rng: np.random.Generator) -> np.ndarray:
    return make_transform(t=rng.normal(size=3), rotvec=rng.normal(size=3))


def _fd_twist(traj: ConstantVelocity | Waypoints, t: float, h: float = 1e-6) -> np.ndarray:
    """(ṗ, ω) of a trajectory by central differences, world frame."""
    Tp, Tm = traj.pose(t + h), traj.pose(t - h)
    v = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
    w = matrix_to_rotvec(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)
    return np.concatenate([v, w])


def test_static_pose_and_zero_twist() -> None:
    T = _random_pose(np.random.default_rng(1))
    traj = Static(T)
    assert np.allclose(traj.pose(3.0), T)
    assert np.allclose(traj.twist(3.0), 0.0)
    assert np.allclose(Static().pose(0.0), np.eye(4))


def test_constant_velocity_twist_matches_finite_difference_of_pose() -> None:
    rng = np.random.default_rng(2)
    for _ in range(10):
        traj = ConstantVelocity(_random_pose(rng), rng.normal(size=3), rng.normal(size=3))
        t = float(rng.uniform(-2, 2))
        assert np.allclose(_fd_twist(traj, t), traj.twist(t), atol=1e-7)


def test_constant_velocity_origin_moves_on_a_straight_line() -> None:
    T0 = make_transform(t=[1.0, 2.0, 3.0], rotvec=[0.1, 0.2, 0.3])
    traj = ConstantVelocity(T0, v=[0.5, 0.0, -1.0], w=[0.0, 0.0, 2.0])
    assert np.allclose(traj.pose(0.0), T0)
    assert np.allclose(traj.pose(2.0)[:3, 3], [2.0, 2.0, 1.0])
    # R(t) = exp(t [w]x) R0: rotation about world z by 2 rad/s * 0.5 s = 1 rad.
    Rz = make_transform(rotvec=[0.0, 0.0, 1.0])[:3, :3]
    assert np.allclose(traj.pose(0.5)[:3, :3], Rz @ T0[:3, :3])


def test_waypoints_endpoints_interpolation_and_twist() -> None:
    P0 = make_transform(t=[0.0, 0.0, 1.0])
    P1 = make_transform(t=[1.0, 0.0, 1.0], rotvec=[0.0, 0.0, np.pi / 2])
    P2 = make_transform(t=[1.0, 2.0, 1.0], rotvec=[0.0, 0.0, np.pi / 2])
    traj = Waypoints([1.0, 3.0, 4.0], [P0, P1, P2])
    # Constant before the first and after the last waypoint, with zero twist.
    assert np.allclose(traj.pose(-5.0), P0) and np.allclose(traj.twist(-5.0), 0.0)
    assert np.allclose(traj.pose(10.0), P2) and np.allclose(traj.twist(10.0), 0.0)
    # Waypoints are hit exactly.
    for t, P in zip([1.0, 3.0, 4.0], [P0, P1, P2]):
        assert np.allclose(traj.pose(t), P)
    # Halfway through the first segment: half the translation, half the rotation.
    mid = traj.pose(2.0)
    assert np.allclose(mid[:3, 3], [0.5, 0.0, 1.0])
    assert np.allclose(matrix_to_rotvec(mid[:3, :3]), [0.0, 0.0, np.pi / 4])
    assert np.allclose(traj.twist(2.0), [0.5, 0, 0, 0, 0, np.pi / 4])
    assert np.allclose(traj.twist(3.5), [0, 2.0, 0, 0, 0, 0])
    # Twist equals the finite difference of the pose inside the segments.
    rng = np.random.default_rng(3)
    poses = [_random_pose(rng) for _ in range(4)]
    traj = Waypoints([0.0, 0.5, 1.5, 2.0], poses)
    for t in (0.2, 0.9, 1.7):
        assert np.allclose(_fd_twist(traj, t), traj.twist(t), atol=1e-6)


def test_waypoints_validation() -> None:
    with pytest.raises(ConfigurationError, match="strictly increasing"):
        Waypoints([0.0, 0.0], [np.eye(4), np.eye(4)])
    with pytest.raises(ShapeError):
        Waypoints([0.0, 1.0], [np.eye(4)])
    with pytest.raises(ShapeError):
        Waypoints([0.0], np.full((1, 4, 4), 2.0))


def test_single_waypoint_is_static() -> None:
    T = make_transform(t=[0.0, 1.0, 0.0])
    traj = Waypoints([2.0], [T])
    assert np.allclose(traj.pose(0.0), T) and np.allclose(traj.pose(9.0), T)
    assert np.allclose(traj.twist(2.0), 0.0)


def test_object_validation() -> None:
    with pytest.raises(GeometryError, match="zero-length axis"):
        Cylinder("c", 0.1, axis=[0.0, 0.0, 0.0], point=[0.0, 0.0, 1.0])
    with pytest.raises(GeometryError, match="radius"):
        Cylinder("c", 0.0, axis=[0.0, 1.0, 0.0], point=[0.0, 0.0, 1.0])
    with pytest.raises(GeometryError, match="radius"):
        Sphere("s", -0.1)
    with pytest.raises(GeometryError, match="zero-length"):
        Line("l", point=[0.0, 0.0, 1.0], direction=[0.0, 0.0, 0.0])
    with pytest.raises(ShapeError):
        PointSet("p", np.zeros((3, 2)))
    with pytest.raises(ShapeError):
        Sphere("s", 0.1, center=[0.0, 0.0])
    with pytest.raises(ConfigurationError):
        Sphere("", 0.1)
    cyl = Cylinder("c", 0.1, axis=[0.0, 2.0, 0.0], point=[0.0, 0.0, 1.0])
    assert np.allclose(cyl.axis, [0.0, 1.0, 0.0])


def test_scene_cmo_composes_base_camera_and_object_poses() -> None:
    rng = np.random.default_rng(4)
    wMb, bMc, wMo = _random_pose(rng), _random_pose(rng), _random_pose(rng)
    scene = Scene([Sphere("ball", 0.1, trajectory=Static(wMo))], wMb=wMb)
    cMo = scene.cMo("ball", bMc, t=0.0)
    # A point of the object seen from the camera, computed the long way round.
    X_o = np.array([0.3, -0.2, 0.5, 1.0])
    X_w = wMo @ X_o
    X_c = np.linalg.solve(wMb @ bMc, X_w)
    assert np.allclose(cMo @ X_o, X_c)
    assert np.allclose(cMo @ inverse(cMo), np.eye(4))
    assert scene.names == ("ball",)


@pytest.mark.parametrize("base_at_origin", [True, False])
def test_scene_cmo_is_bit_identical_to_the_product_of_the_three_poses(base_at_origin) -> None:
    """cMo is inv(bMc) @ bMw @ wMo to the bit; with the base at the world origin the product
    with bMw = I is skipped (it only changes the sign of zeros, which a product ignores)."""
    rng = np.random.default_rng(5)
    wMb = np.eye(4) if base_at_origin else _random_pose(rng)
    wMo = make_transform(t=(0.0, 0.0, 0.5), rotvec=(0.0, 0.0, np.pi / 2))  # exact zeros
    scene = Scene([PointSet("t", np.zeros((1, 3)), trajectory=Static(wMo))], wMb=wMb)
    for i in range(200):
        bMc = make_transform(t=rng.normal(size=3) * (i % 2), rotvec=rng.normal(size=3) * (i % 3))
        want = inverse(bMc) @ inverse(wMb) @ wMo
        got = scene.cMo("t", bMc, 0.1 * i)
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64))
    got[:] = 0.0  # a fresh array: the object's pose is untouched
    assert np.array_equal(scene.object("t").trajectory.wMo, wMo)


def test_scene_cmo_checks_its_inputs() -> None:
    scene = Scene([Sphere("ball", 0.1)])
    with pytest.raises(ShapeError, match="bMc"):
        scene.cMo("ball", np.eye(3))
    with pytest.raises(UnknownNameError, match="'box'"):
        scene.cMo("box", np.eye(4))
    with pytest.raises(ConfigurationError, match="time t must be finite"):
        scene.cMo("ball", np.eye(4), float("inf"))
    assert scene.cMo("ball", np.eye(4), 2).shape == (4, 4)  # an integer time is a time


def test_scene_unknown_name_lists_known_names() -> None:
    scene = Scene([Sphere("ball", 0.1), PointSet("dots", np.zeros((4, 3)))])
    with pytest.raises(UnknownNameError, match=r"'box'.*'ball', 'dots'"):
        scene.object("box")
    with pytest.raises(ConfigurationError, match="duplicate"):
        Scene([Sphere("ball", 0.1), Sphere("ball", 0.2)])


def test_object_twist_in_camera_frame_predicts_point_motion() -> None:
    rng = np.random.default_rng(5)
    for _ in range(5):
        traj = ConstantVelocity(_random_pose(rng), rng.normal(size=3), rng.normal(size=3))
        scene = Scene([PointSet("p", np.zeros((1, 3)), trajectory=traj)], wMb=_random_pose(rng))
        bMc = _random_pose(rng)
        t, h = 0.7, 1e-6
        X_o = rng.normal(size=3)
        X_c = (scene.cMo("p", bMc, t) @ np.append(X_o, 1.0))[:3]
        Xp = (scene.cMo("p", bMc, t + h) @ np.append(X_o, 1.0))[:3]
        Xm = (scene.cMo("p", bMc, t - h) @ np.append(X_o, 1.0))[:3]
        v_o = scene.object_twist("p", bMc, t)
        # A point of the moving object: Ẋ = v + ω x X (camera held still).
        assert np.allclose((Xp - Xm) / (2 * h), v_o[:3] + np.cross(v_o[3:], X_c), atol=1e-6)
