"""Tests of the joint-space visual task (CM01 eqs. 23-25)."""

from __future__ import annotations

import numpy as np
import pytest

from redservo import ConfigurationError, ShapeError
from redservo.features import CylinderFeature, PointFeature, SphereFeature
from redservo.robots import Afma6, Humanoid9
from redservo.scene import Cylinder, PointSet, Scene, Sphere, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask


def _in_front(robot, q, t_c, rotvec=(0.0, 0.0, 0.0)):
    """World pose of an object placed at t_c (camera frame) from configuration q."""
    return robot.fkine(q) @ make_transform(t=t_c, rotvec=rotvec)


def _four_points_task(robot, q):
    pts = np.array([[-0.05, -0.04, 0.0], [0.06, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.07, 0.06, 0.0]])
    scene = Scene([PointSet("t", pts, trajectory=Static(_in_front(robot, q, (0.05, -0.02, 0.8))))])
    terms = [TaskTerm(PointFeature(p), "t") for p in pts]
    task = VisualTask.from_desired_poses(terms, {"t": make_transform(t=(0.0, 0.0, 0.6))})
    return scene, task


def _fd_J1(task, scene, robot, q, h=1e-6):
    cols = []
    for j in range(robot.n):
        dq = np.zeros(robot.n)
        dq[j] = h
        ep = task.evaluate(scene, robot.fkine(q + dq), robot.jacobian(q + dq)).e1
        em = task.evaluate(scene, robot.fkine(q - dq), robot.jacobian(q - dq)).e1
        cols.append((ep - em) / (2 * h))
    return np.array(cols).T


@pytest.mark.parametrize("seed", range(5))
def test_J1_matches_finite_differences_of_e1(seed: int) -> None:
    """J1 = C L J(q) is the true derivative of e1 w.r.t. q (chain of robot and features)."""
    rng = np.random.default_rng(seed)
    robot = Afma6()
    lim = robot.limits()
    q = lim.center + rng.uniform(-0.6, 0.6, 6) * lim.range / 2
    scene, task = _four_points_task(robot, q)
    state = task.evaluate(scene, robot.fkine(q), robot.jacobian(q))
    assert state.J1.shape == (6, 6)  # 8 point coordinates combined down to rank 6
    np.testing.assert_allclose(state.J1, _fd_J1(task, scene, robot, q), atol=1e-6, rtol=1e-5)


def test_combination_matrix_for_redundant_features() -> None:
    """8 point coordinates of rank 6 give C (6 x 8) with J1 full rank (eq. 25)."""
    robot = Afma6()
    q = robot.limits().center
    scene, task = _four_points_task(robot, q)
    assert task.C is not None and task.C.shape == (6, 8)
    np.testing.assert_allclose(task.C @ task.C.T, np.eye(6), atol=1e-12)
    # C spans the range of L* (so no feature error in that range is lost).
    L_star = task.desired_interaction()
    np.testing.assert_allclose(task.C.T @ task.C @ L_star, L_star, atol=1e-10)
    state = task.evaluate(scene, robot.fkine(q), robot.jacobian(q))
    assert np.linalg.matrix_rank(state.J1) == 6


def test_single_point_needs_no_combination_and_reduces_to_eq_26() -> None:
    robot = Afma6()
    q = robot.limits().center
    scene = Scene(
        [PointSet("p", np.zeros((1, 3)), trajectory=Static(_in_front(robot, q, (0.1, 0.2, 1.0))))]
    )
    task = VisualTask([TaskTerm(PointFeature(), "p")], [0.0, 0.0])
    assert task.C is None and task.m == 2
    st = task.evaluate(scene, robot.fkine(q), robot.jacobian(q))
    x, y, Z = 0.1, 0.2, 1.0
    L = np.array(
        [[-1 / Z, 0, x / Z, x * y, -(1 + x * x), y], [0, -1 / Z, y / Z, 1 + y * y, -x * y, -x]]
    )
    np.testing.assert_allclose(st.s, [x, y], atol=1e-12)
    np.testing.assert_allclose(st.L, L, atol=1e-12)
    np.testing.assert_allclose(st.J1, L @ robot.jacobian(q), atol=1e-12)
    np.testing.assert_allclose(st.e1, [x, y], atol=1e-12)


def test_depth_modes_and_depth_scale() -> None:
    robot = Afma6()
    q = robot.limits().center
    scene = Scene(
        [PointSet("p", np.zeros((1, 3)), trajectory=Static(_in_front(robot, q, (0.1, 0.0, 2.0))))]
    )
    desired = {"p": make_transform(t=(0.0, 0.0, 1.0))}
    terms = [TaskTerm(PointFeature(), "p")]
    J = robot.jacobian(q)
    Ls = {
        mode: VisualTask.from_desired_poses(terms, desired, depth=mode)
        .evaluate(scene, robot.fkine(q), J)
        .L
        for mode in ("current", "desired", "mean")
    }
    assert Ls["current"][0, 0] == pytest.approx(-1 / 2.0)
    assert Ls["desired"][0, 0] == pytest.approx(-1 / 1.0)
    assert Ls["mean"][0, 0] == pytest.approx(-0.5 * (1 / 2.0 + 1 / 1.0))
    scaled = VisualTask.from_desired_poses(terms, desired).evaluate(
        scene, robot.fkine(q), J, depth_scale=2.0
    )
    assert scaled.L[0, 0] == pytest.approx(-1 / 4.0)  # Ẑ = 2 Z
    np.testing.assert_allclose(scaled.L[:, 3:], Ls["current"][:, 3:])  # rotation part unchanged


def test_sphere_moments_variant_gets_a_combination_matrix() -> None:
    robot = Humanoid9()
    q = robot.rest_configuration()
    scene = Scene([Sphere("s", 0.1, trajectory=Static(_in_front(robot, q, (0.05, 0.0, 1.2))))])
    task = VisualTask.from_desired_poses(
        [TaskTerm(SphereFeature(0.1, variant="moments"), "s")], {"s": make_transform(t=(0, 0, 0.9))}
    )
    assert task.C is not None and task.C.shape == (3, 5)
    st = task.evaluate(scene, robot.fkine(q), robot.jacobian(q))
    assert st.J1.shape == (3, 9) and np.linalg.matrix_rank(st.J1) == 3


def test_angle_errors_are_wrapped() -> None:
    """The cylinder's θ2 = π: a measured θ2 of -π + ε must give a small error."""
    robot = Afma6(tool="generic")
    q = robot.limits().center
    bMc = robot.fkine(q)
    cyl = Cylinder(
        "c", 0.05, np.array([0.0, 1.0, 0.0]), trajectory=Static(bMc @ make_transform(t=(0, 0, 1.0)))
    )
    feat = CylinderFeature(0.05, (0.0, 1.0, 0.0))
    task = VisualTask.from_desired_poses(
        [TaskTerm(feat, "c")], {"c": make_transform(t=(0, 0, 1.0))}
    )
    e = task.error(task.s_star + np.array([0.0, 0.0, 0.0, 2 * np.pi - 1e-3]))
    assert np.all(np.abs(e) <= np.pi)
    assert abs(e[3]) == pytest.approx(1e-3)
    st = task.evaluate(Scene([cyl]), bMc, robot.jacobian(q))
    np.testing.assert_allclose(st.e, 0.0, atol=1e-9)


def test_bad_task_input() -> None:
    terms = [TaskTerm(PointFeature(), "p")]
    with pytest.raises(ShapeError, match="s_star"):
        VisualTask(terms, [0.0, 0.0, 0.0])
    with pytest.raises(ConfigurationError, match="depth"):
        VisualTask(terms, [0.0, 0.0], depth="nearest")  # type: ignore[arg-type]
    with pytest.raises(ConfigurationError, match="desired pose"):
        VisualTask(terms, [0.0, 0.0], depth="desired")
    with pytest.raises(ConfigurationError, match="at least one"):
        VisualTask([], [])


def test_moment_orientation_error_has_period_pi() -> None:
    """The task delegates wrapping to each feature: α (an orientation) wraps with period π."""
    from redservo.features import MomentFeatures

    pts = np.array([[-0.05, -0.04, 0.0], [0.07, -0.05, 0.0], [0.04, 0.06, 0.0], [-0.06, 0.03, 0.0]])
    desired = make_transform(t=(0.0, 0.0, 0.6))
    feat = MomentFeatures.at_desired_pose(pts, desired)
    task = VisualTask.from_desired_poses([TaskTerm(feat, "t")], {"t": desired})
    s = task.s_star.copy()
    s[3] += np.pi - 0.01  # α + π - 0.01 is the same orientation as α - 0.01
    assert task.error(s)[3] == pytest.approx(-0.01)


def test_a_subclass_overriding_measure_error_or_interaction_is_honoured() -> None:
    """The hot path of a points task must not bypass a subclass's own methods (a constant
    interaction matrix, CM01 eq. 27 as printed, is such a subclass)."""
    robot = Afma6()
    lim = robot.limits()
    q = 0.5 * (lim.q_min + lim.q_max)
    scene, task = _four_points_task(robot, q)
    L_const = np.arange(48, dtype=float).reshape(8, 6) / 48.0

    class ConstantL(VisualTask):
        def interaction(self, s, inv_depth, *, depth_scale=1.0):
            return L_const.copy()

    class Shifted(VisualTask):
        def error(self, s):
            return super().error(s) + 1.0

    terms, s_star = task.terms, task.s_star
    const = ConstantL(terms, s_star, inv_depth_star=task.inv_depth_star, C=np.eye(8))
    shifted = Shifted(terms, s_star, inv_depth_star=task.inv_depth_star, C=np.eye(8))
    bMc, J = robot.fkine(q), robot.jacobian(q)
    for state in (
        const.evaluate(scene, bMc, J),
        const.evaluate_measured(*task.measure(scene, bMc, 0.0), J),
    ):
        np.testing.assert_array_equal(state.L, L_const)
        np.testing.assert_array_equal(state.J1, L_const @ J)
    plain = task.evaluate(scene, bMc, J)
    np.testing.assert_array_equal(shifted.evaluate(scene, bMc, J).e, plain.e + 1.0)
