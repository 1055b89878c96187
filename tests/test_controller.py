"""redservo.Controller: the one control core every loop drives (issue 18, item 1)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

import redservo
from redservo import METHODS, ConfigurationError, Controller, JointLimits, ShapeError, make_law
from redservo.control import (
    JointLimitForce,
    Measurement,
    ObjectiveContext,
    SceneContext,
)
from redservo.control.feedforward import known_feedforward
from redservo.features import PointFeature
from redservo.redundancy.costs import joint_limit_force
from redservo.robots import Afma6
from redservo.scene import ConstantVelocity, PointSet, Scene
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

Q = np.array([0.1, -0.2, 0.35, 0.4, 0.3, -0.2])
PTS = np.array([[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0.0]])
DT = 0.04


def _setup(v: float = 0.0) -> tuple[Afma6, Scene, VisualTask]:
    """Afma6 facing a 4-point square 0.6 m away (moving along y at ``v`` m/s)."""
    robot = Afma6()
    wMo = robot.fkine(Q) @ make_transform(t=(0.03, -0.02, 0.6))
    traj = ConstantVelocity(wMo, v=np.array([0.0, v, 0.0]))
    scene = Scene([PointSet("square", PTS, trajectory=traj)])
    terms = [TaskTerm(PointFeature(p), "square") for p in PTS]
    s_star = np.array([-0.1, -0.1, 0.1, -0.1, 0.1, 0.1, -0.1, 0.1])
    return robot, scene, VisualTask(terms, s_star)


def _measure(robot: Afma6, scene: Scene, task: VisualTask, q: np.ndarray, t: float = 0.0):
    bMc, J = robot.kinematics(q)
    s, inv_depth = task.measure(scene, bMc, t)
    return Measurement(s, inv_depth), J, bMc


def _same(a: Any, b: Any) -> bool:
    """Field by field equality of two diagnostics (arrays compared exactly)."""
    fa, fb = dataclasses.asdict(a), dataclasses.asdict(b)
    return fa.keys() == fb.keys() and all(
        np.array_equal(fa[k], fb[k]) if isinstance(fa[k], np.ndarray) else fa[k] == fb[k]
        for k in fa
    )


@pytest.mark.parametrize("method", METHODS)
def test_step_is_the_law_called_by_hand_bit_for_bit(method: str) -> None:
    robot, scene, task = _setup()
    limits = robot.limits()
    meas, J, _ = _measure(robot, scene, task, Q)
    prev = np.full(6, 0.01)
    state = task.evaluate_measured(meas.s, meas.inv_depth, J)
    law = make_law(method)
    if hasattr(law, "observe"):  # predictive: the controller hands it its model first
        law.observe(robot, task, state)
    by_hand = law(J1=state.J1, e1=state.e1, q=Q, limits=limits, lam=0.7, dt=DT, qdot_prev=prev)
    ctrl = Controller(robot, task, make_law(method), limits, lam=0.7, dt=DT)
    for J_given in (J, None):  # given, or computed by the controller's robot
        ctrl.reset()  # a stateful law (predictive's warm start) starts afresh
        step = ctrl.step(Q, meas, 0.0, qdot_prev=prev, J=J_given)
        assert np.array_equal(step.qdot, by_hand.qdot)
        assert np.array_equal(step.state.J1, state.J1) and np.array_equal(step.state.e1, state.e1)
        assert _same(step.diagnostics, by_hand.diagnostics)
        assert step.stop is None and step.secondary is None and step.de1_dt is None
        assert not step.saturated


class Recording:
    """A plain-Python law that records its keywords and returns a fixed command."""

    def __init__(self) -> None:
        self.calls: list[dict[str, Any]] = []
        self.resets = 0

    def __call__(self, **kw: Any) -> Any:
        self.calls.append(kw)
        return make_law("classical")(**kw)

    def reset(self) -> None:
        self.resets += 1


def test_objectives_are_summed_in_order_into_the_laws_secondary() -> None:
    robot, scene, task = _setup()
    law = Recording()
    a, b = np.linspace(0.1, 0.6, 6), np.full(6, 1e-3)
    objs = [lambda ctx: (a, None), lambda ctx: (None, None), lambda ctx: (b, None)]
    ctrl = Controller(robot, task, law, lam=0.5, dt=DT, objectives=objs)
    meas, J, _ = _measure(robot, scene, task, Q)
    step = ctrl.step(Q, meas, 0.0, qdot_prev=None, J=J)
    assert np.array_equal(step.secondary, a + b)
    assert law.calls[-1]["secondary"] is step.secondary
    force = JointLimitForce(kappa=2.0)
    ctrl = Controller(robot, task, law, lam=0.5, dt=DT, objectives=[force])
    ctrl.step(Q, meas, 0.0, qdot_prev=None)
    assert np.array_equal(law.calls[-1]["secondary"], joint_limit_force(Q, robot.limits(), kappa=2))


def test_the_first_objective_that_stops_wins_and_no_law_is_called() -> None:
    robot, scene, task = _setup()
    law = Recording()
    seen: list[ObjectiveContext] = []

    def watcher(ctx: ObjectiveContext) -> tuple[None, None]:
        seen.append(ctx)
        return None, None

    def never(ctx: ObjectiveContext) -> Any:
        raise AssertionError("an objective after the stopping one was called")

    objs = [watcher, lambda ctx: (None, "occluded"), lambda ctx: (None, "other"), never]
    ctrl = Controller(robot, task, law, lam=0.5, dt=DT, objectives=objs)
    meas, _, bMc = _measure(robot, scene, task, Q)
    step = ctrl.step(Q, meas, 0.3, qdot_prev=None, context=SceneContext(scene, bMc))
    assert step.stop == "occluded" and not law.calls
    assert step.diagnostics is None and not step.qdot.any() and step.qdot.shape == (6,)
    ctx = seen[0]  # what an objective sees
    assert ctx.scene is scene and ctx.bMc is bMc and ctx.robot is robot and ctx.t == 0.3
    assert np.array_equal(ctx.J, robot.jacobian(Q)) and ctx.state is step.state


def test_reset_resets_the_law_the_objectives_and_the_feedforward() -> None:
    robot, scene, task = _setup(v=0.05)
    law = Recording()

    class Counting:
        resets = 0

        def __call__(self, ctx: ObjectiveContext) -> tuple[None, None]:
            return None, None

        def reset(self) -> None:
            self.resets += 1

    obj = Counting()
    ctrl = Controller(robot, task, law, lam=0.5, dt=DT, objectives=[obj], feedforward="estimated")
    prev = np.zeros(6)
    first = [ctrl.step(Q, _measure(robot, scene, task, Q, k * DT)[0], k * DT, qdot_prev=prev)
             for k in range(3)]  # fmt: skip
    assert first[0].de1_dt is None and first[1].de1_dt is not None
    ctrl.reset()
    assert law.resets == 1 and obj.resets == 1
    again = ctrl.step(Q, _measure(robot, scene, task, Q, 0.0)[0], 0.0, qdot_prev=prev)
    assert again.de1_dt is None and np.array_equal(again.qdot, first[0].qdot)
    wln = make_law("wln", mode="history")  # a law with state of its own
    ctrl = Controller(robot, task, wln, lam=0.5, dt=DT)
    meas = _measure(robot, scene, task, Q)[0]
    one = ctrl.step(Q, meas, 0.0, qdot_prev=prev).qdot
    ctrl.step(Q + 0.01, meas, DT, qdot_prev=prev)
    assert not np.array_equal(ctrl.step(Q, meas, 0.0, qdot_prev=prev).qdot, one)  # remembers
    ctrl.step(Q + 0.01, meas, DT, qdot_prev=prev)
    ctrl.reset()
    assert np.array_equal(ctrl.step(Q, meas, 0.0, qdot_prev=prev).qdot, one)


def test_estimated_feedforward_is_the_error_change_less_the_robots_own_motion() -> None:
    robot, scene, task = _setup(v=0.05)
    ctrl = Controller(robot, task, make_law("classical"), lam=0.5, dt=DT, feedforward="estimated")
    m0, m1 = (_measure(robot, scene, task, Q, t)[0] for t in (0.0, DT))
    s0 = ctrl.step(Q, m0, 0.0, qdot_prev=np.zeros(6))
    qdot = np.full(6, 0.02)
    s1 = ctrl.step(Q, m1, 0.1 * 0.4, qdot_prev=qdot)  # 0.04000000000000001: one period
    expected = (s1.state.e1 - s0.state.e1) / DT - s0.state.J1 @ qdot
    assert np.array_equal(s1.de1_dt, expected)
    s2 = ctrl.step(Q, m1, 0.04 + 2 * DT, qdot_prev=qdot)  # two periods later: h = 2 dt
    assert np.allclose(s2.de1_dt, (s2.state.e1 - s1.state.e1) / (2 * DT) - s1.state.J1 @ qdot)
    with pytest.raises(ConfigurationError, match="increase") as info:
        ctrl.step(Q, m1, 0.0, qdot_prev=qdot)
    assert info.value.argument == "t"


def test_known_feedforward_comes_from_the_scene_context() -> None:
    robot, scene, task = _setup(v=0.05)
    ctrl = Controller(robot, task, make_law("classical"), lam=0.5, dt=DT, feedforward="known")
    meas, _, bMc = _measure(robot, scene, task, Q, 0.2)
    step = ctrl.step(Q, meas, 0.2, qdot_prev=None, context=SceneContext(scene, bMc))
    assert np.array_equal(step.de1_dt, known_feedforward(task, scene, bMc, 0.2, DT))
    assert np.linalg.norm(step.de1_dt) > 0.01  # the target moves
    with pytest.raises(ConfigurationError, match="SceneContext") as info:
        ctrl.step(Q, meas, 0.2, qdot_prev=None)
    assert info.value.argument == "feedforward"


def test_output_saturation_scales_the_command_and_keeps_its_direction() -> None:
    robot, scene, task = _setup()
    meas = _measure(robot, scene, task, Q)[0]
    free = Controller(robot, task, make_law("classical"), lam=5.0, dt=DT).step(
        Q, meas, 0.0, qdot_prev=None
    )
    cap = 0.5 * float(np.max(np.abs(free.qdot)))
    ctrl = Controller(robot, task, make_law("classical"), lam=5.0, dt=DT, qdot_saturation=cap)
    step = ctrl.step(Q, meas, 0.0, qdot_prev=None)
    assert step.saturated and np.max(np.abs(step.qdot)) == pytest.approx(cap, rel=1e-12)
    np.testing.assert_allclose(step.qdot * 2.0, free.qdot, rtol=1e-12)


def test_a_plain_python_law_gets_only_the_keywords_it_takes() -> None:
    robot, scene, task = _setup()
    got: list[set[str]] = []

    def plain(*, J1: Any, e1: Any, q: Any, limits: Any, lam: Any, dt: Any) -> Any:
        got.append({"J1", "e1", "q", "limits", "lam", "dt"})
        return make_law("classical")(J1=J1, e1=e1, q=q, limits=limits, lam=lam, dt=dt)

    ctrl = Controller(robot, task, plain, lam=0.5, dt=DT)
    assert ctrl.accepts == frozenset({"J1", "e1", "q", "limits", "lam", "dt"})
    step = ctrl.step(Q, _measure(robot, scene, task, Q)[0], 0.0, qdot_prev=np.zeros(6))
    assert got and step.qdot.shape == (6,)


def _bad(**changes: Any) -> dict[str, Any]:
    robot, _, task = _setup()
    kw: dict[str, Any] = {"robot": robot, "task": task, "law": make_law("classical"),
                          "lam": 0.5, "dt": DT}  # fmt: skip
    kw.update(changes)
    return kw


@pytest.mark.parametrize(
    ("changes", "error", "argument"),
    [
        ({"lam": 0.0}, ConfigurationError, "lam"),
        ({"lam": float("nan")}, ConfigurationError, "lam"),
        ({"lam": "fast"}, ConfigurationError, "lam"),
        ({"dt": -0.04}, ConfigurationError, "dt"),
        ({"feedforward": "magic"}, ConfigurationError, "feedforward"),
        ({"depth_scale": 0.0}, ConfigurationError, "depth_scale"),
        ({"qdot_saturation": [1.0, 2.0]}, ShapeError, "qdot_saturation"),
        ({"qdot_saturation": -1.0}, ConfigurationError, "qdot_saturation"),
        ({"limits": JointLimits([-1.0], [1.0])}, ShapeError, "limits"),
        ({"law": "classical"}, ConfigurationError, "law"),
        ({"law": lambda J1, e1, q: None}, ConfigurationError, "law"),
        ({"objectives": [JointLimitForce(), 3]}, ConfigurationError, "objectives[1]"),
        ({"robot": "afma6"}, ConfigurationError, "robot"),
        ({"task": None}, ConfigurationError, "task"),
    ],
)  # fmt: skip
def test_bad_arguments_are_named(changes: dict[str, Any], error: type, argument: str) -> None:
    kw = _bad(**changes)
    with pytest.raises(error, match=argument.split("[")[0]) as info:
        Controller(kw.pop("robot"), kw.pop("task"), kw.pop("law"), kw.pop("limits", None), **kw)
    assert info.value.argument == argument


def test_bad_step_inputs_are_named() -> None:
    robot, scene, task = _setup()
    ctrl = Controller(robot, task, make_law("classical"), lam=0.5, dt=DT)
    meas, J, _ = _measure(robot, scene, task, Q)
    cases = [
        ({"q": Q[:5]}, "q"),
        ({"measurement": Measurement(meas.s[:6], meas.inv_depth)}, "measurement.s"),
        ({"measurement": Measurement(meas.s, meas.inv_depth[:2])}, "measurement.inv_depth"),
        ({"J": J[:, :5]}, "J"),
    ]
    for change, argument in cases:
        kw: dict[str, Any] = {"q": Q, "measurement": meas, "J": J, **change}
        with pytest.raises(ShapeError) as info:
            ctrl.step(kw["q"], kw["measurement"], 0.0, qdot_prev=None, J=kw["J"])
        assert info.value.argument == argument


def test_controller_is_public() -> None:
    assert "Controller" in redservo.__all__ and redservo.Controller is Controller
    robot, _, task = _setup()
    assert "iterative-smooth" in repr(Controller(robot, task, make_law("iterative-smooth"),
                                                 lam=0.5, dt=DT))  # fmt: skip
