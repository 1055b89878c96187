"""Tests of the robot models: Jacobians against finite differences, DH conventions, bad input."""

from __future__ import annotations

import copy
import doctest
import math
from collections.abc import Callable

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import redservo.robots.dh
from redservo.errors import (
    ConfigurationError,
    JointLimitError,
    ShapeError,
    UnknownNameError,
)
from redservo.robots import (
    ROBOTS,
    Afma6,
    DHLink,
    DHRobot,
    Humanoid9,
    Panda,
    Robot,
    make_robot,
)
from redservo.robots.afma6 import COUPLING
from redservo.robots.humanoid import JOINT_GROUPS
from redservo.spatial import inverse, log_transform, make_transform, twist_transform

# -- models under test ----------------------------------------------------------------------------


def custom_links() -> list[DHLink]:
    """A 5-joint arm with a prismatic joint, non-zero offsets and constant thetas."""
    return [
        DHLink(d=0.30, alpha=np.pi / 2, offset=0.2, q_min=-2.5, q_max=2.5, name="waist"),
        DHLink(a=0.40, alpha=0.1, theta=0.0, offset=-0.3, q_min=-1.5, q_max=1.5, name="shoulder"),
        DHLink(
            a=0.05,
            alpha=-np.pi / 2,
            d=0.1,
            theta=0.4,
            joint_type="prismatic",
            offset=0.05,
            q_min=0.0,
            q_max=0.3,
            name="slide",
        ),
        DHLink(a=0.10, d=0.2, alpha=np.pi / 2, offset=0.7, q_min=-2.0, q_max=2.0, name="wrist1"),
        DHLink(a=0.02, d=0.08, alpha=-0.3, q_min=-2.8, q_max=2.8, name="wrist2"),
    ]


def custom_robot(convention: str) -> DHRobot:
    return DHRobot(
        custom_links(),
        convention=convention,  # type: ignore[arg-type]
        base=make_transform(t=(0.1, -0.2, 0.5), rotvec=(0.1, 0.2, -0.3)),
        flange=make_transform(t=(0.0, 0.01, 0.12), rotvec=(0.0, 0.3, 0.0)),
        eMc=make_transform(t=(0.03, -0.02, 0.05), rotvec=(0.2, -0.1, 0.5)),
        name=f"custom-{convention}",
    )


MODELS: dict[str, Callable[[], Robot]] = {
    "afma6-ccmop": lambda: Afma6(tool="ccmop"),
    "afma6-generic": lambda: Afma6(tool="generic"),
    "humanoid9": Humanoid9,
    "panda": Panda,
    "dh-standard": lambda: custom_robot("standard"),
    "dh-modified": lambda: custom_robot("modified"),
}


def random_q(robot: Robot, rng: np.random.Generator, margin: float = 0.02) -> np.ndarray:
    """A uniform random configuration at least ``margin`` x range inside the limits."""
    lo = robot.q_min + margin * (robot.q_max - robot.q_min)
    hi = robot.q_max - margin * (robot.q_max - robot.q_min)
    return rng.uniform(lo, hi)


def fd_body_jacobian(fk: Callable[[np.ndarray], np.ndarray], q: np.ndarray, h: float = 1e-6):
    """Central differences of the pose, as the body twist: log(T(q)^-1 T(q ± h e_j)) / 2h."""
    T0inv = inverse(fk(q))
    J = np.empty((6, q.shape[0]))
    for j in range(q.shape[0]):
        e = np.zeros_like(q)
        e[j] = h
        J[:, j] = (log_transform(T0inv @ fk(q + e)) - log_transform(T0inv @ fk(q - e))) / (2 * h)
    return J


def assert_jacobian_close(J: np.ndarray, J_fd: np.ndarray, rel: float = 1e-6) -> None:
    err = np.linalg.norm(J - J_fd)
    assert err <= rel * np.linalg.norm(J), f"|J - J_fd| = {err:.3g}, |J| = {np.linalg.norm(J):.3g}"


# -- Jacobians against finite differences ---------------------------------------------------------


@pytest.mark.parametrize("model", list(MODELS))
def test_camera_jacobian_matches_finite_differences(model: str) -> None:
    robot = MODELS[model]()
    rng = np.random.default_rng(10)
    for _ in range(25):
        q = random_q(robot, rng)
        J = robot.jacobian(q)
        assert J.shape == (6, robot.n)
        assert_jacobian_close(J, fd_body_jacobian(robot.fkine, q))


@pytest.mark.parametrize("model", list(MODELS))
def test_ee_jacobian_matches_finite_differences(model: str) -> None:
    robot = MODELS[model]()
    rng = np.random.default_rng(11)
    for _ in range(25):
        q = random_q(robot, rng)
        J = robot.jacobe(robot.check_q(q))
        assert_jacobian_close(J, fd_body_jacobian(robot.fkine_ee, q))


@pytest.mark.parametrize("model", list(MODELS))
def test_poses_are_rigid_and_camera_is_composed(model: str) -> None:
    robot = MODELS[model]()
    rng = np.random.default_rng(12)
    for _ in range(10):
        q = random_q(robot, rng)
        T = robot.fkine(q)
        assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
        assert np.isclose(np.linalg.det(T[:3, :3]), 1.0)
        assert np.allclose(T[3], [0, 0, 0, 1])
        assert np.allclose(T, robot.fkine_ee(q) @ robot.eMc)


# -- independent checks of the DH machinery -------------------------------------------------------


def test_planar_2r_by_hand() -> None:
    l1, l2 = 0.7, 0.4
    arm = DHRobot([DHLink(a=l1), DHLink(a=l2)], name="planar")
    for q1, q2 in [(0.0, 0.0), (0.3, -1.1), (2.0, 0.5), (-2.9, 3.0)]:
        T = arm.fkine_ee(np.array([q1, q2]))
        c12, s12 = math.cos(q1 + q2), math.sin(q1 + q2)
        assert np.allclose(
            T[:3, 3], [l1 * math.cos(q1) + l2 * c12, l1 * math.sin(q1) + l2 * s12, 0]
        )
        assert np.allclose(T[:3, :3], [[c12, -s12, 0], [s12, c12, 0], [0, 0, 1]])
        # In the end-effector frame the linear part is (l1 sin q2, l1 cos q2 + l2) for joint 1
        # and (0, l2) for joint 2; both joints turn about z.
        expected = np.array(
            [
                [l1 * math.sin(q2), 0.0],
                [l1 * math.cos(q2) + l2, l2],
                [0.0, 0.0],
                [0.0, 0.0],
                [0.0, 0.0],
                [1.0, 1.0],
            ]
        )
        assert np.allclose(arm.jacobe(np.array([q1, q2])), expected)


def test_prismatic_joint_by_hand() -> None:
    # A revolute joint about z, then a slide along the rotated x axis (alpha = -pi/2 turns z_1 onto
    # the horizontal plane); offset 0.1 m on the slide.
    arm = DHRobot(
        [
            DHLink(alpha=-np.pi / 2, q_min=-3, q_max=3),
            DHLink(theta=0.0, joint_type="prismatic", offset=0.1, q_min=0.0, q_max=1.0),
        ]
    )
    q1, q2 = 0.6, 0.25
    T = arm.fkine_ee(np.array([q1, q2]))
    # The slide moves along z_1 = Rz(q1) Rx(-pi/2) e_z = Rz(q1) (0, 1, 0) = (-sin q1, cos q1, 0).
    assert np.allclose(T[:3, 3], (q2 + 0.1) * np.array([-math.sin(q1), math.cos(q1), 0.0]))
    J = arm.jacobe(np.array([q1, q2]))
    assert np.allclose(J[3:, 1], 0.0)  # a prismatic joint has no angular velocity
    assert np.isclose(np.linalg.norm(J[:3, 1]), 1.0)


def standard_to_modified(links: list[DHLink]) -> tuple[list[DHLink], np.ndarray]:
    """Rewrite a standard-DH table as a modified one with the same frames at the tip.

    ``Rz(θ1)Tz(d1) [Tx(a1)Rx(α1)] Rz(θ2)Tz(d2) [Tx(a2)Rx(α2)] ⋯`` regrouped: the
    modified row i carries (a_{i-1}, α_{i-1}) and the last (a_n, α_n) becomes the
    flange ``Tx(a_n) Rx(α_n)`` (Tx and Rx commute).
    """
    out = []
    prev_a, prev_alpha = 0.0, 0.0
    for link in links:
        out.append(
            DHLink(
                a=prev_a,
                alpha=prev_alpha,
                d=link.d,
                theta=link.theta,
                joint_type=link.joint_type,
                offset=link.offset,
                q_min=link.q_min,
                q_max=link.q_max,
                name=link.name,
            )
        )
        prev_a, prev_alpha = link.a, link.alpha
    ca, sa = math.cos(prev_alpha), math.sin(prev_alpha)
    flange = np.array([[1, 0, 0, prev_a], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
    return out, flange


def test_standard_and_modified_describe_the_same_arm() -> None:
    rng = np.random.default_rng(13)
    for _ in range(5):
        links = [
            DHLink(
                a=rng.uniform(-0.5, 0.5),
                alpha=rng.uniform(-np.pi, np.pi),
                d=rng.uniform(-0.5, 0.5),
                theta=rng.uniform(-1, 1),
                joint_type="prismatic" if k == 1 else "revolute",
                offset=rng.uniform(-0.5, 0.5),
                q_min=-1.0,
                q_max=1.0,
            )
            for k in range(3)
        ]
        std = DHRobot(links, convention="standard")
        mod_links, flange = standard_to_modified(links)
        mod = DHRobot(mod_links, convention="modified", flange=flange)
        for _ in range(5):
            q = rng.uniform(-0.9, 0.9, size=3)
            assert np.allclose(std.fkine(q), mod.fkine(q), atol=1e-12)
            assert np.allclose(std.jacobian(q), mod.jacobian(q), atol=1e-12)


def test_docstring_example_runs() -> None:
    result = doctest.testmod(redservo.robots.dh, verbose=False)
    assert result.attempted > 0
    assert result.failed == 0


def test_fkine_ee_returns_a_copy_of_the_cache() -> None:
    robot = Panda()
    q = Panda.ready_configuration()
    T = robot.fkine_ee(q)
    T[:] = 0.0
    assert np.allclose(robot.fkine_ee(q)[3], [0, 0, 0, 1])
    # A new q (even a tiny change) is not served from the cache.
    q2 = q.copy()
    q2[0] += 1e-3
    assert not np.allclose(robot.fkine_ee(q2), robot.fkine_ee(q))


# -- the Panda ------------------------------------------------------------------------------------


def test_panda_zero_configuration() -> None:
    # With every joint at zero (joint 4 is then outside its range) the arm is stretched upward,
    # the flange pointing down:
    # x = a4 + a5 + a7 = 0.088, z = d1 + d3 + d5 - d_flange = 0.926.
    robot = Panda()
    T = robot.fkine_ee(np.zeros(7))  # fkine_ee does not check limits
    assert np.allclose(T[:3, 3], [0.088, 0.0, 0.926])
    assert np.allclose(T[:3, :3], np.diag([1.0, -1.0, -1.0]))
    with pytest.raises(JointLimitError, match="panda_joint4"):
        robot.fkine(np.zeros(7))


def test_panda_ready_configuration() -> None:
    robot = Panda()
    q = Panda.ready_configuration()
    assert np.allclose(q, [0, -np.pi / 4, 0, -3 * np.pi / 4, 0, np.pi / 2, np.pi / 4])
    assert robot.limits().contains(q)
    T = robot.fkine(q)
    assert T[2, 2] < -0.99  # the wrist camera looks down at the table
    assert np.linalg.matrix_rank(robot.jacobian(q)) == 6


# -- the Afma6 ------------------------------------------------------------------------------------


def test_afma6_ccmop_looks_up_the_base_z_axis_at_zero() -> None:
    robot = Afma6(tool="ccmop")
    z_c = robot.fkine(np.zeros(6))[:3, 2]
    assert z_c @ np.array([0.0, 0.0, 1.0]) > math.cos(math.radians(1.0))
    # ... because the CCMOP optical axis is close to x_e and x_e is +z_f at q = 0.
    assert robot.eMc[:3, 2] @ np.array([1.0, 0.0, 0.0]) > math.cos(math.radians(1.0))
    assert np.allclose(robot.fkine_ee(np.zeros(6))[:3, 0], [0.0, 0.0, 1.0])


def test_afma6_ccmop_hand_eye_matches_the_published_values() -> None:
    robot = Afma6()
    assert np.allclose(robot.eMc[:3, 3], [0.0117, 0.0033, 0.2272])
    rxyz = Rotation.from_matrix(robot.eMc[:3, :3]).as_euler("XYZ", degrees=True)
    assert np.allclose(rxyz, [164.35, 89.64, -73.05], atol=0.01)
    assert np.allclose(Afma6(tool="generic").eMc, np.eye(4))


def test_afma6_joints_b_and_c_are_coupled() -> None:
    """Turning B alone also turns the tool about the C axis by -g dB; B with C += g dB does not."""
    robot = Afma6(tool="generic")
    rng = np.random.default_rng(14)
    for _ in range(5):
        q = random_q(robot, rng, margin=0.2)
        a = q[3]
        b_axis = np.array([math.cos(a), math.sin(a), 0.0])  # B turns about a horizontal axis
        dB = 0.3
        R0 = robot.fkine_ee(q)[:3, :3]
        rot_b = Rotation.from_rotvec(dB * b_axis).as_matrix()
        q_comp = q + np.array([0, 0, 0, 0, dB, COUPLING * dB])
        assert np.allclose(robot.fkine_ee(q_comp)[:3, :3], rot_b @ R0, atol=1e-12)
        q_b = q + np.array([0, 0, 0, 0, dB, 0])
        residual = Rotation.from_matrix(robot.fkine_ee(q_b)[:3, :3] @ (rot_b @ R0).T)
        assert np.isclose(residual.magnitude(), COUPLING * dB, rtol=1e-6)
    assert COUPLING == 0.009091


def test_afma6_limits_and_names() -> None:
    robot = Afma6()
    assert robot.joint_names == ("x", "y", "z", "A", "B", "C")
    assert robot.joint_types == ("prismatic",) * 3 + ("revolute",) * 3
    assert np.allclose(robot.q_min, [-0.6501, -0.6001, -0.5001, -2.7301, -0.1001, -1.5901])
    assert np.allclose(robot.q_max, [0.7001, 0.5201, 0.4601, 2.7301, 2.4801, 1.5901])
    newer = Afma6(joint_limits="visp2024")
    assert np.allclose(newer.q_min, [-0.7501, -0.6501, -0.5001, -2.7301, -0.3001, -1.5901])
    with pytest.raises(UnknownNameError, match="ccmop"):
        Afma6(tool="kinect")
    with pytest.raises(UnknownNameError, match=r"visp3\.5"):
        Afma6(joint_limits="2001")


# -- the humanoid ---------------------------------------------------------------------------------


def test_humanoid_rest_configuration_looks_forward_within_limits() -> None:
    robot = Humanoid9()
    q = robot.rest_configuration()
    assert q.shape == (9,)
    assert np.all(robot.limits().margin(q) >= 0.2)
    T = robot.fkine(q)
    assert np.allclose(T[:3, 2], [1.0, 0.0, 0.0])  # gaze horizontal, straight ahead
    assert np.allclose(T[:3, 0], [0.0, -1.0, 0.0])  # image x to the right
    assert np.allclose(T[:3, 3], [0.09, 0.0, 0.936 * 1.75])  # eyes at eye height
    assert np.linalg.matrix_rank(robot.jacobian(q)) == 6


def test_humanoid_joint_groups_and_ranges() -> None:
    robot = Humanoid9()
    assert Humanoid9.JOINT_GROUPS == JOINT_GROUPS
    assert JOINT_GROUPS == {"pelvis": (0, 1, 2), "spine": (3,), "neck": (4, 5, 6), "eyes": (7, 8)}
    assert sorted(i for g in JOINT_GROUPS.values() for i in g) == list(range(9))
    rng = robot.q_max - robot.q_min
    eyes, neck = rng[[7, 8]], rng[[4, 5, 6]]
    assert eyes.max() < 0.5 * neck.min()  # much smaller than the neck
    # Per axis: yaw, roll, pitch of the neck smaller than those of the pelvis.
    by_axis = {"yaw": (6, 0), "roll": (5, 1), "pitch": (4, 2)}
    for neck_i, pelvis_i in by_axis.values():
        assert rng[neck_i] < rng[pelvis_i]
    assert np.all(rng < 2 * np.pi)


@pytest.mark.parametrize(
    ("joint", "check"),
    [
        ("pelvis_yaw", lambda T0, T: T[1, 2] > 0.1),  # gaze turns left
        ("neck_yaw", lambda T0, T: T[1, 2] > 0.1),
        ("eye_pan", lambda T0, T: T[1, 2] > 0.1),
        ("eye_tilt", lambda T0, T: T[2, 2] < -0.1),  # gaze goes down
        ("neck_pitch", lambda T0, T: T[2, 2] < -0.1),
        ("spine_pitch", lambda T0, T: T[0, 3] > T0[0, 3]),  # eyes move forward
        ("pelvis_pitch", lambda T0, T: T[0, 3] > T0[0, 3]),
        ("pelvis_roll", lambda T0, T: T[1, 3] < -0.05),  # lean right
        ("neck_roll", lambda T0, T: T[1, 3] < -0.01),
    ],
)
def test_humanoid_joint_senses(joint: str, check: Callable[..., bool]) -> None:
    robot = Humanoid9()
    i = robot.joint_names.index(joint)
    q = robot.rest_configuration()
    q[i] = 0.2
    assert check(robot.fkine(robot.rest_configuration()), robot.fkine(q))


def test_humanoid_stature_scales_lengths() -> None:
    small, tall = Humanoid9(stature=1.5), Humanoid9(stature=2.0)
    q = Humanoid9.rest_configuration()
    assert np.isclose(small.fkine(q)[2, 3], 0.936 * 1.5)
    assert np.isclose(tall.fkine(q)[2, 3], 0.936 * 2.0)
    with pytest.raises(ConfigurationError):
        Humanoid9(stature=10.0)


# -- bad input ------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", list(MODELS))
def test_bad_q_is_rejected(model: str) -> None:
    robot = MODELS[model]()
    q = random_q(robot, np.random.default_rng(15))
    ragged = [*q.tolist()[:-1], [1.0, 2.0]]
    words = ["a"] * robot.n
    for bad in (q[:-1], np.append(q, 0.0), q[None, :], ragged, words, None):
        with pytest.raises(ShapeError):
            robot.fkine(bad)
    for value in (np.nan, np.inf):
        q_bad = q.copy()
        q_bad[0] = value
        with pytest.raises(ShapeError):
            robot.jacobian(q_bad)
    for i in (0, robot.n - 1):
        q_out = q.copy()
        q_out[i] = robot.q_max[i] + 0.01
        with pytest.raises(JointLimitError, match=repr(robot.joint_names[i])):
            robot.fkine(q_out)
        with pytest.raises(JointLimitError, match=repr(robot.joint_names[i])):
            robot.jacobian(q_out)
        # ... unless the caller opts out of the limit check.
        assert np.all(np.isfinite(robot.fkine(q_out, check_limits=False)))


def test_unknown_robot_lists_known_names() -> None:
    with pytest.raises(UnknownNameError) as info:
        make_robot("puma560")
    for name in ROBOTS:
        assert name in str(info.value)


@pytest.mark.parametrize(
    "eMc",
    [
        np.diag([2.0, 1.0, 1.0, 1.0]),  # scaled
        np.eye(3),  # wrong shape
        np.vstack([np.eye(4)[:3], [0.0, 0.0, 1.0, 1.0]]),  # bad last row
        np.diag([1.0, 1.0, -1.0, 1.0]),  # reflection
        np.full((4, 4), np.nan),
    ],
)
def test_non_rigid_eMc_is_rejected(eMc: np.ndarray) -> None:
    robot = Panda()
    with pytest.raises(ShapeError):
        robot.eMc = eMc
    with pytest.raises(ShapeError):
        Panda(eMc=eMc)


def test_dh_link_and_robot_validation() -> None:
    with pytest.raises(ConfigurationError, match="prismatic"):
        DHLink(joint_type="prismatic")
    with pytest.raises(ConfigurationError):
        DHLink(joint_type="spherical")  # type: ignore[arg-type]
    with pytest.raises(JointLimitError):
        DHLink(q_min=1.0, q_max=0.5)
    with pytest.raises(ShapeError):
        DHLink(a=float("nan"))
    with pytest.raises(ConfigurationError):
        DHRobot([])
    with pytest.raises(ConfigurationError):
        DHRobot([DHLink()], convention="craig")  # type: ignore[arg-type]
    with pytest.raises(ShapeError):
        DHRobot([DHLink()], base=np.ones((4, 4)))
    arm = DHRobot([DHLink(), DHLink(a=1.0, q_min=-1.0, q_max=1.0, name="elbow")])
    assert arm.joint_names == ("q1", "elbow")
    assert np.allclose(arm.q_min, [-np.pi, -1.0])


# -- ikine, eMc, make_robot -----------------------------------------------------------------------


@pytest.mark.parametrize("model", list(MODELS))
def test_ikine_round_trip(model: str) -> None:
    robot = MODELS[model]()
    rng = np.random.default_rng(16)
    for _ in range(3):
        q_true = random_q(robot, rng, margin=0.15)
        target = robot.fkine(q_true)
        q0 = np.clip(
            q_true + 0.05 * rng.standard_normal(robot.n) * (robot.q_max - robot.q_min),
            robot.q_min,
            robot.q_max,
        )
        q = robot.ikine(target, q0)
        assert robot.limits().contains(q)
        assert np.allclose(robot.fkine(q), target, atol=1e-8)


@pytest.mark.parametrize("model", list(MODELS))
def test_setting_eMc_changes_fkine_and_jacobian_consistently(model: str) -> None:
    robot = MODELS[model]()
    q = random_q(robot, np.random.default_rng(17))
    J_before = robot.jacobian(q)
    new = make_transform(t=(0.1, -0.05, 0.2), rotvec=(0.4, -0.3, 1.0))
    twin = copy.copy(robot)  # what the simulator does to model hand-eye errors
    twin.eMc = new
    assert np.allclose(robot.jacobian(q), J_before)  # the original is untouched
    assert np.allclose(twin.fkine(q), robot.fkine_ee(q) @ new)
    assert np.allclose(twin.jacobian(q), twist_transform(inverse(new)) @ robot.jacobe(q))
    assert_jacobian_close(twin.jacobian(q), fd_body_jacobian(twin.fkine, q))


def test_make_robot() -> None:
    assert ROBOTS == ("afma6", "humanoid9", "panda")
    classes = {"afma6": Afma6, "humanoid9": Humanoid9, "panda": Panda}
    for name in ROBOTS:
        robot = make_robot(name)
        assert isinstance(robot, classes[name])
        assert robot.name == name
    assert isinstance(make_robot(" Panda "), Panda)
    assert np.allclose(make_robot("afma6", tool="generic").eMc, np.eye(4))
    with pytest.raises(UnknownNameError):
        make_robot("afma6", tool="nope")
    with pytest.raises(ConfigurationError, match="afma6"):
        make_robot("afma6", wheels=4)


@pytest.mark.parametrize("make", [Afma6, Humanoid9, Panda])
def test_kinematics_equals_fkine_and_jacobian(make: type) -> None:
    """The combined hot-path call returns exactly fkine(q) and jacobian(q)."""
    robot = make()
    rng = np.random.default_rng(7)
    lim = robot.limits()
    for _ in range(20):
        q = lim.q_min + rng.uniform(0.05, 0.95, robot.n) * lim.range
        bMc, J = robot.kinematics(q)
        np.testing.assert_allclose(bMc, robot.fkine(q), atol=1e-14)
        np.testing.assert_allclose(J, robot.jacobian(q), atol=1e-14)
