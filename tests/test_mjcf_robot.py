"""MJCFRobot (issue 30 item 5): kinematics against MuJoCo, our URDF and finite differences;
its collision capsules; its bad input."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="MJCF robots need redservo[mujoco]")

from redservo.collision import Obstacle, Shape, distances
from redservo.errors import ConfigurationError, GeometryError, JointLimitError, UnknownNameError
from redservo.robots import MJCFRobot, shipped_mjcf
from redservo.robots.mjcf_collision import enclosing_capsule
from redservo.robots.pack import CHAIN
from redservo.scene import Static
from redservo.spatial import inverse, log_transform, make_transform

RNG = np.random.default_rng(7)

# Rotated bodies, a joint off its body origin, a non-zero ref, a slide, a locked joint, a
# ball joint off the chain, a site with its own rotation: everything the chain folds in.
ARM = """<mujoco model="arm">
  <compiler angle="radian"/>
  <worldbody>
    <body name="stand" pos="0.1 0.2 0.3" euler="0.1 0.2 0.3">
      <geom type="box" size="0.1 0.1 0.05"/>
      <body name="a" pos="0 0 0.1" quat="0.9 0.1 0.2 0.3">
        <joint name="j1" axis="0 0 1" pos="0.02 0.01 0" ref="0.3" range="-2 2"/>
        <geom type="capsule" size="0.04" fromto="0 0 0 0 0 0.3"/>
        <body name="b" pos="0 0 0.3" euler="1.2 0 0.4">
          <joint name="j2" axis="0 1 0" range="-1.5 1.5"/>
          <joint name="lock" axis="1 0 0" range="-1 1"/>
          <geom type="cylinder" size="0.03 0.1" pos="0.1 0 0" euler="0 1.5708 0"/>
          <body name="c" pos="0.2 0 0" euler="0 0.5 0">
            <joint name="j3" type="slide" axis="1 0 0" pos="0.1 0 0" ref="0.05" range="0 0.2"/>
            <geom type="sphere" size="0.05"/>
            <site name="camera" pos="0.1 0.02 0" euler="0.3 1.5 0.2"/>
            <body name="free_part" pos="0.1 0 0">
              <joint name="ball" type="ball"/>
              <geom type="sphere" size="0.01" contype="0" conaffinity="0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _arm(tmp_path: Path, **kw: object) -> MJCFRobot:
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    return MJCFRobot(path, tip="camera", joints=["j1", "j2", "j3"], **kw)  # type: ignore[arg-type]


def _random_q(robot: MJCFRobot) -> np.ndarray:
    return RNG.uniform(robot.q_min, robot.q_max)


@pytest.mark.parametrize("name", ["panda", "ur5e"])
def test_menagerie_chain_equals_mujocos_own_kinematics(name: str) -> None:
    robot = MJCFRobot(shipped_mjcf(name), tip="camera")
    assert robot.n == {"panda": 7, "ur5e": 6}[name]
    for _ in range(20):
        q = _random_q(robot)
        bMc, J = robot.kinematics(q)
        ref_M, ref_J = robot.mujoco_kinematics(q)
        np.testing.assert_allclose(bMc, ref_M, atol=1e-12)
        np.testing.assert_allclose(J, ref_J, atol=1e-12)


def test_folded_refs_offsets_and_locked_joints_equal_mujoco(tmp_path: Path) -> None:
    robot = _arm(tmp_path, locked_q={"lock": 0.4}, eMc=make_transform(t=(0.0, 0.01, 0.02)))
    np.testing.assert_array_equal(robot._data.qpos[-4:], [1.0, 0.0, 0.0, 0.0])  # ball at qpos0
    assert robot.joint_types == ("revolute", "revolute", "prismatic")
    assert robot.base == "stand" and robot.locked_q["lock"] == 0.4
    for _ in range(20):
        q = _random_q(robot)
        bMc, J = robot.kinematics(q)
        ref_M, ref_J = robot.mujoco_kinematics(q)
        np.testing.assert_allclose(bMc, ref_M, atol=1e-12)
        np.testing.assert_allclose(J, ref_J, atol=1e-12)


def test_panda_from_menagerie_equals_our_urdf_panda() -> None:
    pytest.importorskip("pinocchio", reason="the URDF path needs redservo[urdf]")
    from redservo.robots import URDFRobot, shipped_urdf

    mj = MJCFRobot(shipped_mjcf("panda"), tip="camera")
    urdf = URDFRobot(shipped_urdf("panda"), camera_link="camera_link")
    np.testing.assert_array_equal(mj.q_min, urdf.q_min)
    np.testing.assert_array_equal(mj.q_max, urdf.q_max)
    worst = 0.0
    for _ in range(50):
        q = _random_q(mj)
        (M1, J1), (M2, J2) = mj.kinematics(q), urdf.kinematics(q)
        worst = max(worst, float(np.abs(M1 - M2).max()), float(np.abs(J1 - J2).max()))
    assert worst < 1e-9, worst


@pytest.mark.parametrize("name", ["panda", "ur5e"])
def test_jacobian_is_the_camera_twist_by_finite_differences(name: str) -> None:
    # v_c = J q̇ in the camera frame (z forward): a small joint step moves the camera by
    # exp(J dq) in its own frame.
    robot = MJCFRobot(shipped_mjcf(name), tip="camera", eMc=make_transform(t=(0.0, 0.0, 0.01)))
    h = 1e-6
    for _ in range(5):
        q = RNG.uniform(robot.q_min + 0.1, robot.q_max - 0.1)
        J = robot.jacobian(q)
        M0 = robot.fkine(q)
        for i in range(robot.n):
            dq = np.zeros(robot.n)
            dq[i] = h
            twist = (
                log_transform(inverse(M0) @ robot.fkine(q + dq))
                - log_transform(inverse(M0) @ robot.fkine(q - dq))
            ) / (2 * h)
            np.testing.assert_allclose(twist, J[:, i], atol=1e-7)


def test_the_robot_packs_for_the_compiled_engine_and_pickles(tmp_path: Path) -> None:
    robot = _arm(tmp_path)
    pack = robot.kernel_pack()
    assert pack is not None and pack[0] == CHAIN
    copy = pickle.loads(pickle.dumps(robot))
    q = _random_q(robot)
    np.testing.assert_array_equal(copy.fkine(q), robot.fkine(q))
    np.testing.assert_allclose(copy.mujoco_kinematics(q)[0], robot.fkine(q), atol=1e-12)


def test_velocity_limits_default_to_the_documented_values_or_the_given_ones(
    tmp_path: Path,
) -> None:
    robot = _arm(tmp_path)
    np.testing.assert_array_equal(robot.qdot_max, [1.0, 1.0, 0.25])
    assert robot.qddot_max is None
    robot = _arm(tmp_path, qdot_max={"j2": 2.0}, qddot_max=5.0)
    np.testing.assert_array_equal(robot.qdot_max, [1.0, 2.0, 0.25])
    np.testing.assert_array_equal(robot.qddot_max, [5.0, 5.0, 5.0])
    with pytest.raises(UnknownNameError, match="'j9' is not a servoed joint"):
        _arm(tmp_path, qdot_max={"j9": 2.0})


# -- collision geometry ----------------------------------------------------------------------------


def test_a_capsule_encloses_every_ball_it_is_fitted_to() -> None:
    for _ in range(50):
        c = RNG.normal(size=(6, 3)) * RNG.uniform(0.01, 0.3, size=3)
        r = RNG.uniform(0.0, 0.05, size=6)
        A, B, R = enclosing_capsule(c, r)
        for ci, ri in zip(c, r):
            s = np.clip(np.dot(ci - A, B - A) / max(np.dot(B - A, B - A), 1e-300), 0.0, 1.0)
            assert np.linalg.norm(ci - (A + s * (B - A))) + ri <= R + 1e-12


def test_ur5e_capsules_enclose_menageries_geoms() -> None:
    robot = MJCFRobot(shipped_mjcf("ur5e"), tip="camera")
    caps = robot.collision_capsules()
    assert [c.name for c in caps][:3] == ["shoulder_link", "upper_arm_link", "forearm_link"]
    q = _random_q(robot)
    O, _ = robot.collision_points(q)
    robot._pose(q)
    m, d = robot._model, robot._data
    bMw = inverse(robot._world_pose(robot._base_id))
    for g in range(m.ngeom):  # sample each capsule/cylinder geom's surface: inside its capsule
        cap = next(c for c in caps if c.name == m.body(m.geom_bodyid[g]).name)
        A, B = O[cap.a], O[cap.b]
        R, x = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g]
        r, half = m.geom_size[g][:2]
        for t in np.linspace(-1, 1, 5):
            for phi in np.linspace(0, 2 * np.pi, 8):
                local = np.array([r * np.cos(phi), r * np.sin(phi), t * half])
                p = (bMw @ np.append(R @ local + x, 1.0))[:3]
                s = np.clip(np.dot(p - A, B - A) / np.dot(B - A, B - A), 0.0, 1.0)
                assert np.linalg.norm(p - (A + s * (B - A))) <= cap.radius + 1e-9


def test_distances_and_their_jacobians_by_finite_differences() -> None:
    robot = MJCFRobot(shipped_mjcf("panda"), tip="camera")
    # A ball (capsule pairs are exact in coal; a cylinder's GJK answer is noisier, 2e-5 m).
    post = Obstacle("ball", Shape("sphere", radius=0.05), Static(make_transform(t=(0.4, 0.2, 0.5))))
    q = np.array([0.0, -0.785, 0.0, -2.8, 0.0, 1.571, 0.785])
    recs = distances(robot, q, [post], self_collision=True)
    kinds = {r.kind for r in recs}
    assert kinds == {"environment", "self"}
    assert min(r.distance for r in recs if r.kind == "self") > 0.0
    h = 1e-6
    for i in range(robot.n):
        dq = np.zeros(robot.n)
        dq[i] = h
        up = distances(robot, q + dq, [post], self_collision=True)
        down = distances(robot, q - dq, [post], self_collision=True)
        for r, u, w in zip(recs, up, down):
            assert (u.first, u.second) == (r.first, r.second)
            fd = (u.distance - w.distance) / (2 * h)
            assert abs(fd - r.jacobian[i]) < 1e-6, (r.first, r.second, i, fd, r.jacobian[i])


def test_a_mesh_geom_is_enclosed_and_a_mesh_outside_the_folder_is_refused(tmp_path: Path) -> None:
    verts = [(0, 0, 0), (0.2, 0, 0), (0, 0.1, 0), (0, 0, 0.05)]
    obj = "".join(f"v {x} {y} {z}\n" for x, y, z in verts) + "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    (tmp_path / "model").mkdir()
    (tmp_path / "model" / "part.obj").write_text(obj)
    (tmp_path / "outside.obj").write_text(obj)
    xml = """<mujoco><asset><mesh name="m" file="FILE"/></asset><worldbody>
      <body name="b"><joint name="j" axis="0 0 1" range="-1 1"/>
        <geom type="mesh" mesh="m"/><site name="tip" pos="0 0 0.1"/></body>
    </worldbody></mujoco>"""
    (tmp_path / "model" / "ok.xml").write_text(xml.replace("FILE", "part.obj"))
    robot = MJCFRobot(tmp_path / "model" / "ok.xml", tip="tip")
    (cap,) = robot.collision_capsules()
    O, _ = robot.collision_points(np.zeros(1))
    A, B = O[cap.a], O[cap.b]
    for v in np.array(verts, dtype=float):
        s = np.clip(np.dot(v - A, B - A) / np.dot(B - A, B - A), 0.0, 1.0)
        assert np.linalg.norm(v - (A + s * (B - A))) <= cap.radius + 1e-9
    (tmp_path / "model" / "bad.xml").write_text(xml.replace("FILE", "../outside.obj"))
    with pytest.raises(GeometryError, match=r"outside.obj.*outside the model's folder"):
        MJCFRobot(tmp_path / "model" / "bad.xml", tip="tip")


# -- bad input --------------------------------------------------------------------------------------


def test_bad_input_names_the_argument(tmp_path: Path) -> None:
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    with pytest.raises(ConfigurationError, match="does not exist"):
        MJCFRobot(tmp_path / "none.xml", tip="camera")
    with pytest.raises(
        UnknownNameError, match="tip: 'cam' is neither a site, a camera nor a body"
    ) as e:
        MJCFRobot(path, tip="cam")
    assert e.value.argument == "tip"
    with pytest.raises(UnknownNameError, match="base: 'nope' is not a body") as e:
        MJCFRobot(path, tip="camera", base="nope")
    assert e.value.argument == "base"
    with pytest.raises(ConfigurationError, match="not below base 'c'"):
        MJCFRobot(path, tip="b", base="c")
    with pytest.raises(ConfigurationError, match=r"'ball' .* is a ball or free joint"):
        MJCFRobot(path, tip="free_part")
    with pytest.raises(ConfigurationError, match="chain order"):
        MJCFRobot(path, tip="camera", joints=["j2", "j1"])
    with pytest.raises(JointLimitError, match=r"locked_q: 'lock' = 2\.0 is outside") as e:
        _arm(tmp_path, locked_q={"lock": 2.0})
    assert e.value.argument == "locked_q"
    with pytest.raises(UnknownNameError, match="'ball' is not a locked hinge or slide"):
        _arm(tmp_path, locked_q={"ball": 0.0})
    (tmp_path / "broken.xml").write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(ConfigurationError, match=r"broken\.xml: cannot read the MJCF"):
        MJCFRobot(tmp_path / "broken.xml", tip="camera")
    (tmp_path / "odd.xml").write_text(
        '<mujoco><worldbody><geom type="nosuch"/></worldbody></mujoco>'
    )
    with pytest.raises(ConfigurationError, match=r"MuJoCo cannot load .*odd\.xml"):
        MJCFRobot(tmp_path / "odd.xml", tip="camera")


def test_a_mujoco_camera_as_tip_is_our_camera_frame(tmp_path: Path) -> None:
    # MuJoCo's <camera> looks along its -z with y up; as a tip it becomes ours (z forward,
    # y down): the same frame as a site turned by π about x, and it sees what MuJoCo's sees.
    xml = ARM.replace(
        '<site name="camera" pos="0.1 0.02 0" euler="0.3 1.5 0.2"/>',
        '<site name="camera" pos="0.1 0.02 0" euler="0.3 1.5 0.2"/>'
        '<camera name="wrist" pos="0.1 0.02 0" euler="0.3 1.5 0.2"/>',
    )
    path = tmp_path / "cam.xml"
    path.write_text(xml)
    joints = ["j1", "j2", "j3"]
    cam = MJCFRobot(path, tip="wrist", joints=joints)
    site = MJCFRobot(path, tip="camera", joints=joints)
    flip = np.diag([1.0, -1.0, -1.0, 1.0])
    for _ in range(10):
        q = _random_q(cam)
        np.testing.assert_allclose(cam.fkine(q), site.fkine(q) @ flip, atol=1e-12)
        M, J = cam.mujoco_kinematics(q)
        np.testing.assert_allclose(cam.fkine(q), M, atol=1e-12)
        np.testing.assert_allclose(cam.jacobian(q), J, atol=1e-12)
        # A point 1 m in front of MuJoCo's camera (its -z) is on our optical axis (+z).
        cam._pose(q)
        d = cam._data
        ahead = d.cam_xpos[0] - d.cam_xmat[0].reshape(3, 3)[:, 2]
        bMw = inverse(cam._world_pose(cam._base_id))
        p = inverse(cam.fkine(q)) @ bMw @ np.append(ahead, 1.0)
        np.testing.assert_allclose(p[:3], [0.0, 0.0, 1.0], atol=1e-12)


def test_every_file_attribute_and_include_stays_inside_the_models_folder(tmp_path: Path) -> None:
    model = tmp_path / "model"
    (model / "parts").mkdir(parents=True)
    (tmp_path / "secret.png").write_bytes(b"x")
    body = '<worldbody><body name="b"><joint name="j" range="-1 1"/><site name="tip"/></body></worldbody>'
    cube = '<asset><texture name="t" type="cube" fileright="../secret.png"/></asset>'
    (model / "cube.xml").write_text(f"<mujoco>{cube}{body}</mujoco>")
    with pytest.raises(GeometryError, match=r"fileright='\.\./secret\.png'.*outside"):
        MJCFRobot(model / "cube.xml", tip="tip")
    # An include inherits meshdir: parts/arm.xml names ../../secret.png under meshdir="parts".
    (model / "parts" / "arm.xml").write_text(
        '<mujoco><asset><mesh file="../../secret.png"/></asset></mujoco>'
    )
    (model / "main.xml").write_text(
        f'<mujoco><compiler meshdir="parts"/><include file="parts/arm.xml"/>{body}</mujoco>'
    )
    with pytest.raises(GeometryError, match=r"arm\.xml: <mesh file='\.\./\.\./secret\.png'>"):
        MJCFRobot(model / "main.xml", tip="tip")


def test_a_mjcf_robot_imports_mujoco_with_the_offscreen_default() -> None:
    """MuJoCo reads MUJOCO_GL at its first import: a MJCF robot loaded first in a process
    must leave the default of redservo.physics (egl) in place, or a MuJoCo simulator or
    camera built later in the same process cannot render (redservo warmup stopped at
    panda-mujoco-4points after menagerie-panda-4points)."""
    import os
    import subprocess
    import sys

    code = (
        "import os, sys\n"
        "from redservo.robots.mjcf import MJCFRobot, shipped_mjcf\n"
        "MJCFRobot(shipped_mjcf('ur5e'), tip='camera')\n"
        "assert 'mujoco' in sys.modules\n"
        "print(os.environ.get('MUJOCO_GL'))\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "egl"
