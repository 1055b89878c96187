"""The Controller's output saturation never breaks the acceleration limit unflagged, and a
measurement whose inverse depths are not a sequence is one named error (issue 32, item 1,
on top of the custom-law guard)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo import Controller, Flag, ShapeError, make_law
from redservo.control import Measurement
from tests.test_controller import DT, Q, _measure, _setup


@pytest.mark.parametrize("engine", ["auto", "python"])
def test_saturation_keeps_the_acceleration_limit(engine: Any) -> None:
    """Moving at 0.9 qdot_max, a saturation of 1e-3 would stop the arm in one period: the
    final guard limits the change to qddot_max dt, flagged."""
    robot, scene, task = _setup()
    meas = _measure(robot, scene, task, Q)[0]
    prev = robot.limits().qdot_max * 0.9
    ctrl = Controller(
        robot, task, make_law("classical"), lam=0.5, dt=DT, qdot_saturation=1e-3, engine=engine
    )
    step = ctrl.step(Q, meas, 0.0, qdot_prev=prev)
    assert step.saturated
    assert np.all(np.abs(step.qdot - prev) <= ctrl.limits.qddot_max * DT * (1 + 1e-9))
    assert step.diagnostics.has(Flag.ACCELERATION_LIMITED)


@pytest.mark.parametrize("engine", ["auto", "python"])
def test_inverse_depths_that_are_not_a_sequence_are_named(engine: Any) -> None:
    robot, scene, task = _setup()
    ctrl = Controller(robot, task, make_law("classical"), lam=0.5, dt=DT, engine=engine)
    meas = _measure(robot, scene, task, Q)[0]
    with pytest.raises(ShapeError, match="one entry per task term") as info:
        ctrl.step(Q, Measurement(meas.s, 3), 0.0, qdot_prev=None)  # type: ignore[arg-type]
    assert info.value.argument == "measurement.inv_depth"
