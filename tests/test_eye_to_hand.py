"""Eye-to-hand: a fixed camera, a target carried by the robot (redservo.robots.eye_to_hand)."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.features import (
    CylinderFeature,
    LineFeature,
    MomentFeatures,
    PointFeature,
    SphereFeature,
)
from redservo.robots import make_robot
from redservo.robots.eye_to_hand import EyeToHandRobot
from redservo.spatial import inverse, make_transform

Q0 = np.array([0.1, -0.6, 0.2, -2.2, 0.1, 1.7, 0.6])
SQUARE = np.array([[-0.05, -0.04, 0.0], [0.05, -0.05, 0.0], [0.06, 0.05, 0.0], [-0.05, 0.04, 0.0]])


def _setup() -> tuple[EyeToHandRobot, np.ndarray]:
    """A Panda carrying a target 0.1 m in front of its flange; the camera 0.5 m away from it."""
    panda = make_robot("panda")
    eMo = make_transform(rotvec=[0.1, -0.2, 0.05], t=[0.01, 0.02, 0.1])
    cMo = make_transform(rotvec=[0.2, 0.1, -0.3], t=[0.03, -0.02, 0.5])
    bMc = panda.fkine_ee(Q0) @ eMo @ inverse(cMo)
    return EyeToHandRobot(panda, bMc), eMo


def _features() -> list[object]:
    from redservo.features.pose import PoseThetaU, PoseTranslation

    moments = MomentFeatures(SQUARE, desired_area=0.01, desired_depth=0.5)
    cdMo = make_transform(rotvec=[0.1, 0.0, 0.2], t=[0.0, 0.01, 0.4])
    return [
        PointFeature([0.02, -0.01, 0.0]),
        LineFeature([0.0, 0.01, 0.0], [1.0, 0.3, 0.1]),
        SphereFeature(0.03, [0.0, 0.0, 0.02]),
        CylinderFeature(0.02, [0.2, 1.0, 0.1], [0.0, 0.0, 0.05]),
        moments,
        *(PoseTranslation(v, cdMo) for v in ("cdMc", "cMo", "cMcd")),
        *(PoseThetaU(v, cdMo) for v in ("cdRc", "cRcd")),
    ]


@pytest.mark.parametrize(
    "feature",
    _features(),
    ids=lambda f: f"{type(f).__name__}-{getattr(f, 'variant', '')}".rstrip("-"),
)
def test_task_jacobian_by_finite_differences(feature: object) -> None:
    """``ds/dq = L_s · (−cVe(q) eJe(q))`` against finite differences of the real geometry
    ``cMo(q) = inv(bMc) · bMe(q) · eMo`` (which does not use the wrapper)."""
    robot, eMo = _setup()
    panda, bMc = robot.carrier, robot.bMc

    def s_of(q: np.ndarray) -> np.ndarray:
        return feature.measure(inverse(bMc) @ panda.fkine_ee(q) @ eMo).s  # type: ignore[attr-defined]

    meas = feature.measure(inverse(bMc) @ panda.fkine_ee(Q0) @ eMo)  # type: ignore[attr-defined]
    L = feature.interaction(meas.s, meas.inv_depth)  # type: ignore[attr-defined]
    J = robot.jacobian(Q0)
    h = 1e-6
    fd = np.column_stack(
        [(s_of(Q0 + h * np.eye(7)[j]) - s_of(Q0 - h * np.eye(7)[j])) / (2 * h) for j in range(7)]
    )
    if isinstance(feature, LineFeature | CylinderFeature):  # θ components: wrap the difference
        fd = np.column_stack(
            [
                np.angle(np.exp(1j * (s_of(Q0 + h * e) - s_of(Q0 - h * e)))) / (2 * h)
                for e in np.eye(7)
            ]
        )
    np.testing.assert_allclose(L @ J, fd, atol=2e-6 * max(1.0, np.abs(fd).max()))


def test_pose_and_kinematics_agree() -> None:
    robot, eMo = _setup()
    eMc, J = robot.kinematics(Q0)
    np.testing.assert_allclose(eMc, robot.fkine(Q0))
    np.testing.assert_allclose(J, robot.jacobian(Q0))
    # cMo seen through the wrapper's "camera pose" is the real relative pose.
    cMo_real = inverse(robot.bMc) @ robot.carrier.fkine_ee(Q0) @ eMo
    np.testing.assert_allclose(inverse(eMc) @ eMo, cMo_real, atol=1e-12)


def test_sign_differs_from_eye_in_hand() -> None:
    """A camera on the effector and a target carried by it see opposite motions."""
    robot, _ = _setup()
    panda = robot.carrier
    from redservo.spatial import twist_transform

    cVe = twist_transform(inverse(robot.bMc) @ panda.fkine_ee(Q0))
    np.testing.assert_allclose(robot.jacobian(Q0), -cVe @ panda.jacobe(Q0))


def test_no_compiled_kinematics() -> None:
    """The campaign's compiled loop (and its iteration the benchmarks time) refuse it by type
    (never silently with the carrier's eye-in-hand kinematics)."""
    from redservo.bench.sensed import sensed_iteration
    from redservo.campaign.fastloop import fast_run
    from redservo.errors import ConfigurationError
    from redservo.experiment.build import build
    from redservo.scenario import load_scenario

    exp = build(load_scenario("panda-eye-to-hand"))
    with pytest.raises(ConfigurationError, match="EyeToHandRobot"):
        sensed_iteration(
            exp.robot, exp.scene, exp.task, exp.law, limits=exp.limits, lam=0.5, dt=0.04
        )
    summary, path = fast_run(exp, "iterative-smooth", None)
    assert summary is None and "EyeToHandRobot" in path


# -- scenarios ---------------------------------------------------------------------------------


def _data() -> dict:
    import copy

    from redservo.scenario import load_scenario

    return copy.deepcopy(load_scenario("panda-eye-to-hand").data)


def test_every_law_converges_on_the_shipped_scenario() -> None:
    """Every law sees only J1: each drives the carried target to its desired image."""
    from redservo.experiment.build import build
    from redservo.redundancy import METHODS
    from redservo.scenario import load_scenario

    exp = build(load_scenario("panda-eye-to-hand"))
    assert isinstance(exp.robot, EyeToHandRobot)
    for method in METHODS:
        res = exp.run(method=method, max_iterations=60)
        e = np.linalg.norm(res.log.e1, axis=1)
        assert res.outcome in ("max_iterations", "converged"), method
        assert np.all(np.isfinite(res.log.qdot)), method
        assert e[-1] < 0.6 * e[0], method
    assert exp.run().outcome == "converged"


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda d: d["camera"].pop("pose"), "camera.pose"),
        (lambda d: d["camera"].__setitem__("mount", "hand"), "camera.pose"),
        (lambda d: d["camera"].__setitem__("mount", "ceiling"), "camera.mount"),
        (
            lambda d: (
                d["robot"].update(start_pose={"translation": [0, 0, 0.5]}, q0=None)
                or d["robot"].pop("q0")
            ),
            "robot.start_pose",
        ),
        (
            lambda d: d.setdefault("simulation", {}).update(
                eMc_error={"translation": [0, 0, 0.01]}
            ),
            "simulation.eMc_error",
        ),
        (
            lambda d: (
                d["objects"][0].update(pose={"translation": [0, 0, 1]})
                or d["objects"][0].pop("pose_in_effector")
            ),
            "objects[0].pose_in_effector",
        ),
    ],
)
def test_bad_eye_to_hand_keys(edit: object, key: str) -> None:
    from redservo.errors import ScenarioError
    from redservo.experiment.build import build
    from redservo.scenario import parse_scenario

    data = _data()
    edit(data)  # type: ignore[operator]
    with pytest.raises(ScenarioError) as info:
        build(parse_scenario(data, "e2h.toml"))
    assert f"key '{key}'" in str(info.value)


def test_pose_in_effector_needs_a_world_camera() -> None:
    from redservo.errors import ScenarioError
    from redservo.experiment.build import build
    from redservo.scenario import parse_scenario

    data = _data()
    data["camera"] = {}
    with pytest.raises(ScenarioError, match=r"objects\[0\]\.pose_in_effector"):
        build(parse_scenario(data, "e2h.toml"))


def test_controller_engines_agree() -> None:
    """The controller's compiled engine takes the Jacobian from the robot object (it has no
    compiled eye-to-hand kinematics): the same command as the Python path, bit for bit."""
    from redservo.control import Controller, Measurement
    from redservo.experiment.build import build
    from redservo.redundancy import make_law
    from redservo.scenario import load_scenario

    exp = build(load_scenario("panda-eye-to-hand"))
    bMc = exp.robot.fkine(exp.q0)
    s, inv_depth = exp.task.measure(exp.scene, bMc, 0.0)
    cmds = []
    for engine in ("auto", "python"):
        ctrl = Controller(
            exp.robot, exp.task, make_law("iterative-smooth"), exp.limits, lam=0.5, dt=0.04,
            engine=engine,  # type: ignore[arg-type]
        )  # fmt: skip
        step = ctrl.step(exp.q0, Measurement(s, inv_depth), 0.0, qdot_prev=np.zeros(7))
        cmds.append(step.qdot)
    np.testing.assert_array_equal(cmds[0], cmds[1])
    state = exp.task.evaluate_measured(s, inv_depth, exp.robot.jacobian(exp.q0))
    assert float(state.e1 @ (state.J1 @ cmds[0])) < 0  # the error decreases
