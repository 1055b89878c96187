"""The compiled chain (kernels/chain.py, robots/chain.py): URDF robots against Pinocchio, the
real arms of tests/data against their published DH tables, finite differences, the binding."""

from __future__ import annotations

import copy
import math
import pickle
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from redservo import make_law
from redservo.errors import ConfigurationError, ShapeError
from redservo.kernels import chain as kchain
from redservo.robots import DHLink, DHRobot
from redservo.robots.chain import ChainRobot, chain_pack
from redservo.robots.urdf import URDFRobot, shipped_urdf
from redservo.spatial import make_transform
from tests.test_robots import assert_jacobian_close, fd_body_jacobian, random_q

DATA = Path(__file__).parent / "data"
DEG = math.pi / 180
CAMERA = make_transform(t=(0.05, 0.0, 0.1))


def random_chain(rng: np.random.Generator, n: int = 6) -> ChainRobot:
    """A chain of random rigid transforms, tilted axes, revolute and prismatic joints."""
    origins = [
        make_transform(t=rng.uniform(-0.3, 0.3, 3), rotvec=rng.uniform(-2.0, 2.0, 3))
        for _ in range(n)
    ]
    kinds = ["prismatic" if i % 3 == 1 else "revolute" for i in range(n)]
    lo = np.where(np.array(kinds) == "prismatic", -0.2, -2.5)
    return ChainRobot(
        origins,
        rng.normal(size=(n, 3)),
        kinds,  # type: ignore[arg-type]
        make_transform(t=rng.uniform(-0.1, 0.1, 3), rotvec=rng.uniform(-1.0, 1.0, 3)),
        q_min=lo,
        q_max=-lo,
        eMc=make_transform(t=(0.02, -0.01, 0.05), rotvec=(0.1, 0.2, -0.3)),
    )


# -- the chain itself ----------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(4))
def test_chain_jacobians_match_finite_differences(seed: int) -> None:
    rng = np.random.default_rng(seed)
    robot = random_chain(rng, n=3 + seed)
    for _ in range(10):
        q = random_q(robot, rng)
        assert_jacobian_close(robot.jacobian(q), fd_body_jacobian(robot.fkine, q))
        assert_jacobian_close(robot.jacobe(q), fd_body_jacobian(robot.fkine_ee, q))
        bMc, J = robot.kinematics(q)
        assert np.array_equal(bMc, robot.fkine(q)) and np.array_equal(J, robot.jacobian(q))
        np.testing.assert_allclose(bMc, robot.fkine_ee(q) @ robot.eMc, atol=1e-15)
        np.testing.assert_allclose(J, robot.cVe @ robot.jacobe(q), atol=1e-15)


def test_chain_is_the_product_of_its_transforms() -> None:
    """bMe = F_0 M_0 F_1 M_1 ... F_end, M a rotation about / a slide along the unit axis."""
    rng = np.random.default_rng(7)
    robot = random_chain(rng, n=4)
    frames, joints = robot.chain
    q = random_q(robot, rng)
    T = np.eye(4)
    for i in range(4):
        F = np.eye(4)
        F[:3] = frames[i]
        k = joints[i, :3]
        assert np.isclose(np.linalg.norm(k), 1.0)
        M = make_transform(t=q[i] * k) if joints[i, 3] else make_transform(rotvec=q[i] * k)
        T = T @ F @ M
    F = np.eye(4)
    F[:3] = frames[4]
    np.testing.assert_allclose(robot.fkine_ee(q), T @ F, atol=1e-14)


def test_compiled_and_plain_chain_kernels_agree() -> None:
    rng = np.random.default_rng(8)
    robot = random_chain(rng, n=7)
    frames, joints = robot.chain
    for _ in range(5):
        q = random_q(robot, rng)
        args = (q, frames, joints, robot.eMc, robot.cVe)
        fast = kchain.chain_kinematics(*args)
        plain = getattr(kchain.chain_kinematics, "py_func", kchain.chain_kinematics)(*args)
        for a, b in zip(fast, plain, strict=True):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-14)


def test_chain_copies_and_pickles() -> None:
    robot = random_chain(np.random.default_rng(9))
    q = random_q(robot, np.random.default_rng(1))
    for twin in (copy.copy(robot), pickle.loads(pickle.dumps(robot))):
        assert np.array_equal(twin.kinematics(q)[1], robot.kinematics(q)[1])


def test_bad_chains_name_the_argument() -> None:
    eye = [np.eye(4), np.eye(4)]
    cases: list[tuple[dict[str, object], type[Exception], str]] = [
        ({"origins": []}, ConfigurationError, "at least one joint"),
        ({"axes": np.zeros((3, 3))}, ShapeError, "(2, 3)"),
        ({"axes": [[0, 0, 1], [0, 0, 0]]}, ShapeError, "axes[1] is zero"),
        ({"axes": [[0, 0, np.nan], [0, 0, 1]]}, ShapeError, "finite"),
        ({"joint_types": ["revolute", "helical"]}, ConfigurationError, "'helical'"),
        ({"joint_types": ["revolute"]}, ShapeError, "joint types"),
        ({"origins": [np.eye(4), 2 * np.eye(4)]}, ShapeError, "origins[1]"),
        ({"end": np.ones((4, 4))}, ShapeError, "end"),
    ]
    for change, error, needle in cases:
        args: dict[str, object] = {
            "origins": eye,
            "axes": [[0, 0, 1], [1, 0, 0]],
            "joint_types": ["revolute", "prismatic"],
            "end": None,
            **change,
        }
        with pytest.raises(error) as info:
            chain_pack(**args)  # type: ignore[arg-type]
        assert needle in str(info.value), (change, str(info.value))


# -- the real arms of tests/data against their published DH tables -----------------------------


def iiwa7_dh() -> DHRobot:
    """KUKA LBR iiwa 7 R800: d = 0.34, 0.40, 0.40, 0.126 m, a = 0 (standard DH)."""
    d = (0.34, 0.0, 0.4, 0.0, 0.4, 0.0, 0.126)
    alpha = (-1, 1, 1, -1, -1, 1, 0)
    lim = (170, 120, 170, 120, 170, 120, 175)
    links = [
        DHLink(d=d[i], alpha=alpha[i] * math.pi / 2, q_min=-lim[i] * DEG, q_max=lim[i] * DEG)
        for i in range(7)
    ]
    return DHRobot(links, eMc=make_transform(t=(0.05, 0.0, 0.04)))


def stanford_dh() -> DHRobot:
    """The Stanford arm (Corke's Robotics Toolbox table), camera as in stanford.urdf."""
    r = 170 * DEG
    links = [
        DHLink(d=0.412, alpha=-math.pi / 2, q_min=-r, q_max=r),
        DHLink(d=0.154, alpha=math.pi / 2, q_min=-r, q_max=r),
        DHLink(theta=-math.pi / 2, a=0.0203, joint_type="prismatic", q_min=0.3048, q_max=1.27),
        DHLink(alpha=-math.pi / 2, q_min=-r, q_max=r),
        DHLink(alpha=math.pi / 2, q_min=-math.pi / 2, q_max=math.pi / 2),
        DHLink(q_min=-r, q_max=r),
    ]
    return DHRobot(links, eMc=CAMERA)


@pytest.mark.parametrize(("name", "dh"), [("iiwa7", iiwa7_dh), ("stanford", stanford_dh)])
def test_real_urdfs_equal_their_published_dh_tables(name: str, dh: Callable[[], DHRobot]) -> None:
    pytest.importorskip("pinocchio", reason="URDFRobot needs redservo[urdf]")
    robot, model = URDFRobot(DATA / f"{name}.urdf", camera_link="camera_link"), dh()
    assert robot.joint_types == model.joint_types
    np.testing.assert_allclose(robot.q_min, model.q_min, atol=1e-15)
    np.testing.assert_allclose(robot.q_max, model.q_max, atol=1e-15)
    rng = np.random.default_rng(30)
    for _ in range(100):
        q = random_q(model, rng, margin=0.0)
        bMc, J = robot.kinematics(q)
        np.testing.assert_allclose(bMc, model.fkine(q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(J, model.jacobian(q), rtol=0, atol=1e-12)


# -- URDF robots against Pinocchio, their oracle --------------------------------------------------


def generated_urdf(rng: np.random.Generator) -> str:
    """A random URDF: a floating joint above the base, random origins, tilted axes, fixed,
    prismatic, continuous, locked and mimic joints on the chain, and a side branch."""

    def origin() -> str:
        xyz = " ".join(repr(float(v)) for v in rng.uniform(-0.3, 0.3, 3))
        rpy = " ".join(repr(float(v)) for v in rng.uniform(-3.0, 3.0, 3))
        return f'<origin xyz="{xyz}" rpy="{rpy}"/>'

    def axis() -> str:
        return f'<axis xyz="{" ".join(repr(float(v)) for v in rng.normal(size=3))}"/>'

    kinds = ["revolute", "prismatic", "fixed", "continuous", "revolute", "prismatic", "fixed"]
    kinds += ["revolute", "revolute", "fixed"]  # j7 locked, j8 mimics j0
    parts = ['<robot name="generated">', '<link name="world"/>', '<link name="base"/>']
    parts.append(
        '<joint name="free" type="floating"><parent link="world"/><child link="base"/>'
        + origin()
        + "</joint>"
    )
    parent = "base"
    for i, kind in enumerate(kinds):
        child = f"l{i}"
        parts.append(f'<link name="{child}"/>')
        body = origin()
        if kind != "fixed":
            body += axis()
        if kind == "revolute":
            body += '<limit lower="-2.5" upper="2.5" effort="1" velocity="2"/>'
        elif kind == "prismatic":
            body += '<limit lower="-0.2" upper="0.3" effort="1" velocity="0.5"/>'
        elif kind == "continuous":
            body += '<limit effort="1" velocity="3"/>'
        if i == 8:
            body += '<mimic joint="j0" multiplier="2" offset="0.1"/>'
        parts.append(
            f'<joint name="j{i}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="{child}"/>{body}</joint>'
        )
        parent = child
    parts.append('<link name="side"/>')
    parts.append(
        '<joint name="side_joint" type="revolute"><parent link="l1"/><child link="side"/>'
        + origin()
        + axis()
        + '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
    )
    parts.append("</robot>")
    return "\n".join(parts)


def _generated(tmp_path: Path) -> URDFRobot:
    path = tmp_path / "generated.urdf"
    path.write_text(generated_urdf(np.random.default_rng(40)))
    servo = ["j0", "j1", "j3", "j4", "j5"]  # j7 locked, j8 (mimic) locked
    return URDFRobot(
        path,
        camera_link="l9",
        base_link="base",
        joints=servo,
        locked_q={"j7": 0.7, "j8": -0.4, "side_joint": 0.3},
        eMc=make_transform(t=(0.01, 0.02, 0.03), rotvec=(0.2, -0.1, 0.3)),
    )


ORACLE_ROBOTS = ("panda", "ur5e", "iiwa7", "stanford", "generated")


def _oracle_robot(name: str, tmp_path: Path) -> URDFRobot:
    if name in ("panda", "ur5e"):
        return URDFRobot(shipped_urdf(name), camera_link="camera_link")
    if name == "generated":
        return _generated(tmp_path)
    return URDFRobot(DATA / f"{name}.urdf", camera_link="camera_link")


@pytest.mark.parametrize("name", ORACLE_ROBOTS)
def test_urdf_chain_agrees_with_pinocchio_to_1e_12(name: str, tmp_path: Path) -> None:
    """Pose and Jacobian (max abs) on 1000 random q within the limits (issue 18, item 3)."""
    pytest.importorskip("pinocchio", reason="URDFRobot needs redservo[urdf]")
    robot = _oracle_robot(name, tmp_path)
    rng = np.random.default_rng(41)
    worst = 0.0
    for _ in range(1000):
        q = rng.uniform(robot.q_min, robot.q_max)
        bMc, J = robot.kinematics(q)
        ref_bMc, ref_J = robot.pinocchio_kinematics(q)
        worst = max(worst, float(np.abs(bMc - ref_bMc).max()), float(np.abs(J - ref_J).max()))
    assert worst <= 1e-12, worst


def test_generated_urdf_is_a_real_test(tmp_path: Path) -> None:
    """The generated chain has what it claims: tilted axes, two prismatic joints, locks."""
    pytest.importorskip("pinocchio", reason="URDFRobot needs redservo[urdf]")
    robot = _generated(tmp_path)
    assert robot.joint_types == ("revolute", "prismatic", "revolute", "revolute", "prismatic")
    assert robot.urdf_joint_types[2] == "continuous"
    joints = robot.chain.joints
    assert np.all(np.abs(joints[:, :3]).min(axis=1) > 1e-3)  # no axis along a frame axis
    # The locked joints matter: another lock value of j7 moves the camera.
    moved = robot.__class__(
        tmp_path / "generated.urdf",
        camera_link="l9",
        base_link="base",
        joints=list(robot.joint_names),
        locked_q={"j7": -0.7, "j8": -0.4},
    )
    q = np.zeros(5)
    assert not np.allclose(moved.fkine_ee(q), robot.fkine_ee(q))


# -- the campaign's compiled iteration on a URDF robot -----------------------------------------------


def test_the_campaigns_iteration_on_the_urdf_panda_gives_the_public_command() -> None:
    """The campaign loop's kernels bind a URDF robot (the chain kernels) and equal robot.kinematics +
    task.evaluate + law(...) on the panda-urdf-4points task, step by step in a closed loop."""
    pytest.importorskip("pinocchio", reason="URDFRobot needs redservo[urdf]")
    from redservo import METHODS
    from redservo.bench.sensed import sensed_iteration
    from redservo.experiment.build import build
    from redservo.scenario import load_scenario

    exp = build(load_scenario("panda-urdf-4points"))
    robot, scene, task, limits = exp.robot, exp.scene, exp.task, exp.limits
    assert isinstance(robot, URDFRobot)
    lam, dt = float(exp.options.lam), exp.options.dt  # type: ignore[arg-type]
    from redservo.kernels.step import LAW_IDS

    for method in METHODS:
        if method not in LAW_IDS:  # qp, predictive: a solver between kernels
            continue
        law = make_law(method)
        run = sensed_iteration(robot, scene, task, law, limits=limits, lam=lam, dt=dt)
        q, q_ref, prev, prev_ref = exp.q0.copy(), exp.q0.copy(), None, None
        for k in range(30):
            bMc, J = robot.kinematics(q_ref)
            state = task.evaluate(scene, bMc, J, k * dt)
            ref = law(
                J1=state.J1, e1=state.e1, q=q_ref, limits=limits, lam=lam, dt=dt, qdot_prev=prev_ref
            ).qdot
            if k == 0:
                e1, J1 = run.task(q)
                np.testing.assert_allclose(e1, state.e1, rtol=0, atol=1e-12)
                np.testing.assert_allclose(J1, state.J1, rtol=0, atol=1e-10)
            qdot = run(q, prev).copy()
            np.testing.assert_allclose(qdot, ref, rtol=1e-9, atol=1e-12, err_msg=method)
            q, prev = q + dt * qdot, qdot
            q_ref, prev_ref = q_ref + dt * ref, ref
        assert not np.array_equal(q, exp.q0)  # the loop moved the arm


def test_the_campaigns_qp_iteration_on_the_urdf_panda_gives_the_public_command() -> None:
    pytest.importorskip("pinocchio", reason="URDFRobot needs redservo[urdf]")
    from redservo.bench.sensed import sensed_iteration
    from redservo.experiment.build import build
    from redservo.scenario import load_scenario

    exp = build(load_scenario("panda-urdf-4points"))
    robot, scene, task, limits = exp.robot, exp.scene, exp.task, exp.limits
    lam, dt = float(exp.options.lam), exp.options.dt  # type: ignore[arg-type]
    law = make_law("qp", v_max=1.5)
    run = sensed_iteration(robot, scene, task, law, limits=limits, lam=lam, dt=dt)
    prev = np.linspace(-0.05, 0.05, robot.n)
    state = task.evaluate(scene, *robot.kinematics(exp.q0), 0.0)
    ref = law(J1=state.J1, e1=state.e1, q=exp.q0, limits=limits, lam=lam, dt=dt, qdot_prev=prev)
    np.testing.assert_allclose(run(exp.q0, prev), ref.qdot, rtol=1e-9, atol=1e-12)
