"""Manipulability (redservo.control.manipulability): Yoshikawa's measure of the task
Jacobian, its analytic gradient against finite differences, the objective moving the
redundancy towards larger w, and the singularity margin in the summaries."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.control import Controller, Measurement
from redservo.control.manipulability import (
    Manipulability,
    jacobian_derivative,
    manipulability,
    manipulability_gradient,
)
from redservo.errors import ConfigurationError
from redservo.experiment.build import build
from redservo.redundancy import make_law
from redservo.robots import make_robot
from redservo.scenario import load_scenario


def _w(robot: object, A: np.ndarray, q: np.ndarray) -> float:
    return manipulability(A @ robot.jacobian(q, check_limits=False))  # type: ignore[attr-defined]


@pytest.mark.parametrize("name", ["panda", "afma6"])
def test_gradient_matches_finite_differences(name: str) -> None:
    robot = make_robot(name)
    lim = robot.limits()
    rng = np.random.default_rng(1)
    for _ in range(5):
        q = lim.q_min + (lim.q_max - lim.q_min) * rng.uniform(0.2, 0.8, robot.n)
        A = rng.normal(size=(4, 6))
        J = robot.jacobian(q, check_limits=False)
        w, grad = manipulability_gradient(A, J, jacobian_derivative(robot, q, J))
        assert w == pytest.approx(_w(robot, A, q))
        h = 1e-6
        fd = np.array(
            [(_w(robot, A, q + h * e) - _w(robot, A, q - h * e)) / (2 * h) for e in np.eye(robot.n)]
        )
        np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=1e-8 * max(1.0, w))


def test_closed_form_derivative_is_used_for_a_serial_chain() -> None:
    robot = make_robot("panda")
    q = robot.ready_configuration()
    J = robot.jacobian(q, check_limits=False)
    dJ = jacobian_derivative(robot, q, J)
    h = 1e-6
    for i, e in enumerate(np.eye(robot.n)):
        fd = (
            robot.jacobian(q + h * e, check_limits=False)
            - robot.jacobian(q - h * e, check_limits=False)
        ) / (2 * h)
        np.testing.assert_allclose(dJ[i], fd, atol=1e-7)


def test_objective_moves_the_redundancy_towards_larger_w() -> None:
    exp = build(load_scenario("panda-4points"))
    q = exp.q0 + np.array([0.0, 0.0, 0.3, 0.0, 0.2, 0.0, 0.0])  # q0 is a stationary point of w
    J = exp.robot.jacobian(q, check_limits=False)
    s, inv_depth = exp.task.measure(exp.scene, exp.robot.fkine(q, check_limits=False), 0.0)
    meas = Measurement(s, inv_depth)

    def rate(objectives: list[Manipulability]) -> float:
        law = make_law("gpm", shield=False)
        ctrl = Controller(
            exp.robot, exp.task, law, exp.limits, lam=0.5, dt=0.04, objectives=objectives
        )
        step = ctrl.step(q, meas, 0.0, qdot_prev=None, J=J)
        A = np.linalg.lstsq(J.T, step.state.J1.T, rcond=None)[0].T
        _, grad = manipulability_gradient(A, J, jacobian_derivative(exp.robot, q, J))
        return float(grad @ step.qdot)

    assert rate([Manipulability(5.0)]) > rate([])


def test_bad_gain_names_the_argument() -> None:
    with pytest.raises(ConfigurationError) as err:
        Manipulability(0.0)
    assert err.value.argument == "gain"


def test_summary_reports_the_singularity_margin() -> None:
    res = build(load_scenario("panda-4points")).run(method="gpm")
    s = res.summary
    assert s.min_manipulability is not None and s.min_singular_value is not None
    assert 0.0 < s.min_singular_value and 0.0 < s.min_manipulability
    assert "min_manipulability" in s.to_dict()
