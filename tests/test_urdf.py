"""Tests of URDFRobot: the shipped URDFs against the DH models, Jacobians, sub-chains, errors."""

from __future__ import annotations

import copy
import math
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pinocchio", reason="URDFRobot needs the extra redservo[urdf] (Pinocchio)")

import redservo.robots.urdf as urdf_module
from redservo.errors import (
    ConfigurationError,
    JointLimitError,
    RedservoError,
    UnknownNameError,
)
from redservo.robots import DHLink, DHRobot, Panda, URDFRobot, shipped_urdf
from redservo.robots.panda import (
    PANDA_Q_MAX,
    PANDA_Q_MIN,
    PANDA_QDDOT_MAX,
    PANDA_QDOT_MAX,
    WRIST_CAMERA_OFFSET,
)
from redservo.spatial import inverse, make_transform
from tests.test_robots import assert_jacobian_close, fd_body_jacobian, random_q

PANDA_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
UR5E_JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
EXTRA_EMC = make_transform(t=(0.02, -0.03, 0.05), rotvec=(0.3, -0.2, 1.1))


def panda_urdf(**options: object) -> URDFRobot:
    return URDFRobot(shipped_urdf("panda"), camera_link="camera_link", **options)  # type: ignore[arg-type]


def ur5e_urdf(**options: object) -> URDFRobot:
    return URDFRobot(shipped_urdf("ur5e"), camera_link="camera_link", **options)  # type: ignore[arg-type]


def ur5e_dh() -> DHRobot:
    """The UR5e from Universal Robots' standard DH table, camera as in ur5e.urdf."""
    d = (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996)
    a = (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0)
    alpha = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
    links = [
        DHLink(a=a[i], d=d[i], alpha=alpha[i], q_min=-2 * math.pi, q_max=2 * math.pi)
        for i in range(6)
    ]
    return DHRobot(links, convention="standard", eMc=make_transform(t=(0.05, 0.0, 0.04)))


# A small tree: a slide, a continuous turntable, a fixed bracket, a tilted revolute wrist with
# an off-axis origin, a branch (a sensor on its own revolute joint) and the camera.
TINY_URDF = """<?xml version="1.0"?>
<robot name="tiny">
  <link name="world"/>
  <link name="carriage"/>
  <link name="table"/>
  <link name="bracket"/>
  <link name="wrist"/>
  <link name="sensor"/>
  <link name="cam"/>
  <joint name="slide" type="prismatic">
    <parent link="world"/><child link="carriage"/>
    <origin xyz="0.1 0 0.2" rpy="0 0 0"/>
    <axis xyz="1 0 0"/>
    <limit lower="-0.3" upper="0.5" effort="100" velocity="0.25"/>
  </joint>
  <joint name="turntable" type="continuous">
    <parent link="carriage"/><child link="table"/>
    <origin xyz="0 0 0.1" rpy="0 0 0.3"/>
    <axis xyz="0 0 1"/>
    <limit effort="10" velocity="2.0"/>
  </joint>
  <joint name="mount" type="fixed">
    <parent link="table"/><child link="bracket"/>
    <origin xyz="0.2 0.05 0.3" rpy="0.2 -0.1 0.4"/>
  </joint>
  <joint name="tilt" type="revolute">
    <parent link="bracket"/><child link="wrist"/>
    <origin xyz="0.0 0.1 0.05" rpy="0 0.5 0"/>
    <axis xyz="0 0.6 0.8"/>
    <limit lower="-1.2" upper="0.9" effort="5" velocity="1.5"/>
  </joint>
  <joint name="sensor_pan" type="revolute">
    <parent link="table"/><child link="sensor"/>
    <origin xyz="-0.1 0 0.05" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="0.2" upper="1.0" effort="1" velocity="1"/>
  </joint>
  <joint name="optical" type="fixed">
    <parent link="wrist"/><child link="cam"/>
    <origin xyz="0.03 0 0.08" rpy="-1.5707963267948966 0 -1.5707963267948966"/>
  </joint>
</robot>
"""


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.urdf"
    path.write_text(TINY_URDF)
    return path


# -- the shipped URDFs against the DH models -----------------------------------------------------


def test_panda_urdf_equals_dh_panda() -> None:
    robot, dh = panda_urdf(), Panda()
    assert robot.name == "panda"
    assert robot.joint_names == PANDA_JOINTS == dh.joint_names
    assert robot.joint_types == ("revolute",) * 7
    assert np.array_equal(robot.q_min, PANDA_Q_MIN)
    assert np.array_equal(robot.q_max, PANDA_Q_MAX)
    rng = np.random.default_rng(20)
    for _ in range(25):
        q = random_q(dh, rng, margin=0.0)
        np.testing.assert_allclose(robot.fkine(q), dh.fkine(q), rtol=0, atol=1e-10)
        np.testing.assert_allclose(robot.jacobian(q), dh.jacobian(q), rtol=0, atol=1e-10)
        bMc, J = robot.kinematics(q)
        np.testing.assert_allclose(bMc, dh.fkine(q), rtol=0, atol=1e-10)
        np.testing.assert_allclose(J, dh.jacobian(q), rtol=0, atol=1e-10)
    # camera_link is the same wrist camera: the flange (panda_link8) composed with the offset.
    flange = URDFRobot(
        shipped_urdf("panda"), camera_link="panda_link8", eMc=make_transform(t=WRIST_CAMERA_OFFSET)
    )
    q = Panda.ready_configuration()
    np.testing.assert_allclose(flange.fkine_ee(q), dh.fkine_ee(q), atol=1e-12)
    np.testing.assert_allclose(flange.fkine(q), robot.fkine(q), atol=1e-12)


def test_ur5e_urdf_equals_standard_dh() -> None:
    robot, dh = ur5e_urdf(), ur5e_dh()
    assert robot.joint_names == UR5E_JOINTS
    assert np.allclose(robot.q_min, -2 * np.pi) and np.allclose(robot.q_max, 2 * np.pi)
    # Stretched out at q = 0: tool0 at (a2 + a3, -(d4 + d6), d1 - d5).
    tool = URDFRobot(shipped_urdf("ur5e"), camera_link="tool0")
    assert np.allclose(tool.fkine(np.zeros(6))[:3, 3], [-0.8172, -0.2329, 0.0628], atol=1e-12)
    rng = np.random.default_rng(21)
    for _ in range(20):
        q = random_q(dh, rng, margin=0.0)
        np.testing.assert_allclose(robot.fkine(q), dh.fkine(q), rtol=0, atol=1e-10)
        np.testing.assert_allclose(robot.jacobian(q), dh.jacobian(q), rtol=0, atol=1e-10)


def test_rate_limits_are_read_from_the_urdf(tiny: Path) -> None:
    panda = panda_urdf()
    assert np.array_equal(panda.qdot_max, PANDA_QDOT_MAX)  # type: ignore[arg-type]
    # The shipped files carry the datasheet accelerations (<redservo:limit acceleration>).
    assert np.array_equal(panda.qddot_max, PANDA_QDDOT_MAX)  # type: ignore[arg-type]
    assert np.array_equal(panda.limits().qdot_max, panda.qdot_max)  # type: ignore[arg-type]
    assert np.array_equal(panda.limits().qddot_max, Panda().qddot_max)  # type: ignore[arg-type]
    ur5e = ur5e_urdf()
    assert np.array_equal(ur5e.qdot_max, np.full(6, np.pi))  # type: ignore[arg-type]
    assert np.array_equal(ur5e.qddot_max, np.full(6, 5.0))  # type: ignore[arg-type]
    assert np.array_equal(ur5e_urdf(qddot_max=3.0).qddot_max, np.full(6, 3.0))  # type: ignore[arg-type]
    # A sub-chain keeps the velocities of its own joints; a file without accelerations has none.
    sub = URDFRobot(tiny, camera_link="cam", joints=["slide", "tilt"])
    assert np.array_equal(sub.qdot_max, [0.25, 1.5])  # type: ignore[arg-type]
    assert sub.qddot_max is None


# -- Jacobians against finite differences --------------------------------------------------------

VARIANTS = {
    "panda": lambda: panda_urdf(),
    "ur5e": lambda: ur5e_urdf(),
    "panda-subchain-eMc": lambda: panda_urdf(
        joints=["panda_joint2", "panda_joint4", "panda_joint6", "panda_joint7"],
        locked_q={"panda_joint1": 0.4, "panda_joint3": -0.3},
        eMc=EXTRA_EMC,
    ),
    "ur5e-base-link-eMc": lambda: ur5e_urdf(base_link="upper_arm_link", eMc=EXTRA_EMC),
}


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_jacobians_match_finite_differences(variant: str) -> None:
    robot = VARIANTS[variant]()
    rng = np.random.default_rng(22)
    for _ in range(10):
        q = random_q(robot, rng)
        J = robot.jacobian(q)
        assert J.shape == (6, robot.n)
        assert_jacobian_close(J, fd_body_jacobian(robot.fkine, q))
        assert_jacobian_close(robot.jacobe(q), fd_body_jacobian(robot.fkine_ee, q))
        bMc, J2 = robot.kinematics(q)
        np.testing.assert_allclose(bMc, robot.fkine(q), atol=1e-14)
        np.testing.assert_allclose(J2, J, atol=1e-14)
        np.testing.assert_allclose(bMc, robot.fkine_ee(q) @ robot.eMc, atol=1e-14)


def test_subchain_and_base_link_are_slices_of_the_full_robot() -> None:
    full = panda_urdf()
    sub_joints = ["panda_joint2", "panda_joint4", "panda_joint6"]
    locked = {"panda_joint1": 0.4, "panda_joint3": -0.3, "panda_joint5": 0.2, "panda_joint7": 1.0}
    sub = panda_urdf(joints=sub_joints, locked_q=locked)
    assert sub.joint_names == tuple(sub_joints)
    assert sub.locked_q == locked
    cols = [PANDA_JOINTS.index(j) for j in sub_joints]
    rng = np.random.default_rng(23)
    for _ in range(5):
        q_sub = random_q(sub, rng)
        q_full = np.array([locked.get(j, 0.0) for j in PANDA_JOINTS])
        q_full[cols] = q_sub
        np.testing.assert_allclose(sub.fkine(q_sub), full.fkine(q_full), atol=1e-12)
        np.testing.assert_allclose(sub.jacobian(q_sub), full.jacobian(q_full)[:, cols], atol=1e-12)
    # Default locks: 0, or mid-range when 0 is outside the limits (panda_joint4).
    wrist = panda_urdf(joints=["panda_joint5", "panda_joint6", "panda_joint7"])
    assert wrist.locked_q["panda_joint1"] == 0.0
    assert np.isclose(wrist.locked_q["panda_joint4"], 0.5 * (-3.0718 - 0.0698))
    # base_link: the chain below panda_link3, poses relative to panda_link3.
    upper = panda_urdf(base_link="panda_link3")
    assert upper.joint_names == PANDA_JOINTS[3:]
    q = Panda.ready_configuration()
    b3 = full.link_poses(q)["panda_link3"]
    np.testing.assert_allclose(upper.fkine(q[3:]), inverse(b3) @ full.fkine(q), atol=1e-12)


# -- a prismatic and a continuous joint ----------------------------------------------------------


def test_prismatic_and_continuous_joints(tiny: Path) -> None:
    robot = URDFRobot(tiny, camera_link="cam", locked_q={"sensor_pan": 0.5})
    assert robot.name == "tiny"
    assert robot.joint_names == ("slide", "turntable", "tilt")
    assert robot.joint_types == ("prismatic", "revolute", "revolute")
    assert robot.urdf_joint_types == ("prismatic", "continuous", "revolute")
    assert np.allclose(robot.q_min, [-0.3, -2 * np.pi, -1.2])
    assert np.allclose(robot.q_max, [0.5, 2 * np.pi, 0.9])
    assert robot.locked_q == {"sensor_pan": 0.5}
    q = np.array([0.1, 0.7, -0.4])
    # The slide moves the camera along the world x axis, without rotating it.
    dq = np.array([0.2, 0.0, 0.0])
    T0, T1 = robot.fkine(q), robot.fkine(q + dq)
    np.testing.assert_allclose(T1[:3, 3] - T0[:3, 3], [0.2, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(T1[:3, :3], T0[:3, :3], atol=1e-12)
    # The continuous joint is one angle, periodic, and may go past ±π.
    far = np.array([0.1, 0.7 - 2 * np.pi, -0.4])
    np.testing.assert_allclose(robot.fkine(far), T0, atol=1e-12)
    assert robot.limits().contains(np.array([0.0, 4.0, 0.0]))
    rng = np.random.default_rng(24)
    for _ in range(10):
        q = random_q(robot, rng)
        assert_jacobian_close(robot.jacobian(q), fd_body_jacobian(robot.fkine, q))
        J = robot.jacobe(q)
        assert np.allclose(J[3:, 0], 0.0)  # a prismatic joint does not rotate the camera
        assert np.isclose(np.linalg.norm(J[:3, 0]), 1.0)
        # The tilt axis, (0, 0.6, 0.8) in the wrist frame, seen from the camera.
        axis_cam = robot.link_poses(q)["cam"][:3, :3].T @ robot.link_poses(q)["wrist"][:3, :3]
        np.testing.assert_allclose(J[3:, 2], axis_cam @ [0.0, 0.6, 0.8], atol=1e-12)


def test_link_poses(tiny: Path) -> None:
    robot = URDFRobot(tiny, camera_link="cam", joints=["turntable", "tilt"], base_link="carriage")
    assert robot.link_names == ("world", "carriage", "table", "bracket", "wrist", "sensor", "cam")
    q = np.array([0.3, 0.2])
    poses = robot.link_poses(q)
    assert list(poses) == list(robot.link_names)
    np.testing.assert_allclose(poses["carriage"], np.eye(4), atol=1e-12)
    np.testing.assert_allclose(poses["cam"], robot.fkine_ee(q), atol=1e-12)
    # The slide is locked at 0: world sits 0.1 m behind and 0.2 m below the carriage.
    np.testing.assert_allclose(poses["world"][:3, 3], [-0.1, 0.0, -0.2], atol=1e-12)
    # The sensor branch sits at its default lock: mid-range, since 0 is outside [0.2, 1].
    assert robot.locked_q["sensor_pan"] == pytest.approx(0.6)
    for T in poses.values():
        assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
    with pytest.raises(JointLimitError, match="tilt"):
        robot.link_poses([0.0, 2.0])


def test_shipped_urdf_link_poses_and_copies() -> None:
    robot = ur5e_urdf()
    q = np.array([0.1, -1.2, 1.0, -0.5, 0.4, 0.2])
    poses = robot.link_poses(q)
    assert set(poses) == set(robot.link_names) and "tool0" in poses
    np.testing.assert_allclose(poses["camera_link"], robot.fkine(q), atol=1e-12)
    twin = copy.copy(robot)
    twin.eMc = EXTRA_EMC
    np.testing.assert_allclose(twin.fkine(q), robot.fkine(q) @ EXTRA_EMC, atol=1e-12)
    assert twin._data is not robot._data  # each copy has its own Pinocchio work data
    clone = pickle.loads(pickle.dumps(robot))
    np.testing.assert_allclose(clone.jacobian(q), robot.jacobian(q), atol=1e-14)


# -- errors --------------------------------------------------------------------------------------


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.urdf"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("<robot name='x'><link name='a'>", "line 1"),  # not well-formed
        ("<robut name='x'><link name='a'/></robut>", "<robot>"),
        (
            "<robot name='x'><link name='a'/><joint name='j' type='revolute'><parent link='a'/>"
            "<child link='zz'/></joint></robot>",
            "'zz'",
        ),
        (
            "<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='hinge'>"
            "<parent link='a'/><child link='b'/></joint></robot>",
            "'hinge'",
        ),
        ("<robot name='x'><link name='a'/><link name='b'/></robot>", "root links"),
        (
            "<robot name='x'><link name='a'/><link name='b'/><joint name='j' type='revolute'>"
            "<parent link='a'/><child link='b'/><limit lower='x' upper='1'/></joint></robot>",
            "'j'",
        ),
    ],
)
def test_malformed_urdf_names_the_file(tmp_path: Path, text: str, needle: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(ConfigurationError) as info:
        URDFRobot(path, camera_link="b")
    assert str(path) in str(info.value)
    assert needle in str(info.value)


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.urdf"
    with pytest.raises(ConfigurationError, match="does not exist") as info:
        URDFRobot(path, camera_link="cam")
    assert str(path) in str(info.value)


def test_unknown_names_and_bad_chains(tiny: Path) -> None:
    cases: list[tuple[dict[str, object], type[RedservoError], tuple[str, ...]]] = [
        ({"camera_link": "lens"}, UnknownNameError, ("'lens'", "wrist", "carriage")),
        ({"camera_link": "cam", "base_link": "floor"}, UnknownNameError, ("'floor'", "world")),
        ({"camera_link": "sensor", "base_link": "wrist"}, ConfigurationError, ("downstream",)),
        ({"camera_link": "cam", "joints": ["elbow"]}, UnknownNameError, ("'elbow'", "turntable")),
        ({"camera_link": "cam", "joints": ["mount"]}, ConfigurationError, ("'mount'", "slide")),
        ({"camera_link": "cam", "joints": ["sensor_pan"]}, ConfigurationError, ("sensor_pan",)),
        ({"camera_link": "cam", "joints": ["tilt", "slide"]}, ConfigurationError, ("order",)),
        ({"camera_link": "cam", "joints": "tilt"}, ConfigurationError, ("sequence",)),
        ({"camera_link": "bracket", "base_link": "table"}, ConfigurationError, ("no movable",)),
        ({"camera_link": "cam", "locked_q": {"elbow": 0.0}}, UnknownNameError, ("'elbow'",)),
        ({"camera_link": "cam", "locked_q": {"tilt": 0.0}}, ConfigurationError, ("servoed",)),
        (
            {"camera_link": "cam", "locked_q": {"sensor_pan": 3.0}},
            JointLimitError,
            ("sensor_pan",),
        ),
    ]
    for options, error, needles in cases:
        with pytest.raises(error) as info:
            URDFRobot(tiny, **options)  # type: ignore[arg-type]
        assert isinstance(info.value, RedservoError)
        for needle in needles:
            assert needle in str(info.value), (options, str(info.value))


def test_floating_joint_on_the_chain_is_refused(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        TINY_URDF.replace('name="slide" type="prismatic"', 'name="slide" type="floating"'),
    )
    with pytest.raises(ConfigurationError, match=r"'slide'.*floating"):
        URDFRobot(path, camera_link="cam")
    # ... but a floating joint above base_link is simply locked (at Pinocchio's neutral).
    robot = URDFRobot(path, camera_link="cam", base_link="carriage")
    assert robot.joint_names == ("turntable", "tilt")


def test_configuration_outside_the_limits_names_the_joint() -> None:
    robot = panda_urdf()
    q = Panda.ready_configuration()
    q[3] = 0.0
    with pytest.raises(JointLimitError, match="panda_joint4"):
        robot.kinematics(q)


def test_shipped_urdf_names() -> None:
    assert shipped_urdf("panda").is_file() and shipped_urdf(" UR5e ").is_file()
    with pytest.raises(UnknownNameError, match="panda, ur5e"):
        shipped_urdf("kuka")


def test_missing_extra_is_a_configuration_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(urdf_module, "_PIN", None)
    monkeypatch.setitem(sys.modules, "pinocchio", None)  # makes `import pinocchio` fail
    with pytest.raises(ConfigurationError, match=r"pip install 'redservo\[urdf\]'"):
        panda_urdf()


def test_import_redservo_does_not_import_pinocchio() -> None:
    code = (
        "import sys, redservo, redservo.robots\n"
        "assert redservo.robots.URDFRobot.__name__ == 'URDFRobot'\n"
        "assert 'pinocchio' not in sys.modules, 'pinocchio imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


# -- issue 18: the kinematics run the compiled chain; Pinocchio is the loader and the oracle ------


class _NoPinocchio:
    def __getattr__(self, name: str) -> object:
        raise AssertionError(f"pinocchio.{name} was called")


def test_kinematics_run_the_compiled_chain_not_pinocchio(monkeypatch: pytest.MonkeyPatch) -> None:
    robot = panda_urdf(eMc=EXTRA_EMC)
    q = Panda.ready_configuration()
    ref_bMc, ref_J = robot.pinocchio_kinematics(q)
    monkeypatch.setattr(urdf_module, "_PIN", _NoPinocchio())
    bMc, J = robot.kinematics(q)
    for got, want in (
        (bMc, ref_bMc),
        (robot.fkine(q), ref_bMc),
        (J, ref_J),
        (robot.jacobian(q), ref_J),
    ):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(robot.fkine_ee(q) @ EXTRA_EMC, ref_bMc, rtol=0, atol=1e-12)
    np.testing.assert_allclose(robot.cVe @ robot.jacobe(q), ref_J, rtol=0, atol=1e-12)
    with pytest.raises(AssertionError, match="pinocchio"):
        robot.pinocchio_kinematics(q)  # the oracle is Pinocchio itself


def test_a_mimic_joint_on_the_chain_is_refused_or_locked(tmp_path: Path, tiny: Path) -> None:
    """A <mimic> joint cannot be servoed; left out of joints= it is locked (at locked_q), like
    the reduced Pinocchio model, and does not follow the joint it mimics."""
    text = TINY_URDF.replace(
        '<axis xyz="0 0.6 0.8"/>',
        '<axis xyz="0 0.6 0.8"/><mimic joint="turntable" multiplier="0.5" offset="0.1"/>',
    )
    path = _write(tmp_path, text)
    with pytest.raises(ConfigurationError, match=r"'tilt'.*mimics"):
        URDFRobot(path, camera_link="cam")
    robot = URDFRobot(
        path, camera_link="cam", joints=["slide", "turntable"], locked_q={"tilt": 0.3}
    )
    plain = URDFRobot(
        tiny,
        camera_link="cam",
        joints=["slide", "turntable"],
        locked_q={"tilt": 0.3},
    )
    for q in ([0.1, 0.2], [-0.2, 2.5]):
        np.testing.assert_allclose(robot.fkine(q), plain.fkine(q), rtol=0, atol=1e-15)
        np.testing.assert_allclose(robot.fkine(q), robot.pinocchio_kinematics(q)[0], atol=1e-12)
