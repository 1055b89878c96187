"""Latency compensation in the Controller (redservo.control.latency): a delayed measurement
brought to the present with the commands sent since its image was exposed."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.control import Measurement
from redservo.control.latency import CommandHistory
from redservo.errors import ShapeError
from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario


def test_the_history_integrates_only_the_commands_the_camera_has_not_seen() -> None:
    history = CommandHistory(0.1, lambda q: np.eye(6)[:, :2])  # twist = (q̇0, q̇1, 0, ...)
    for k in range(5):  # q̇ = (k, 1) over [0.1 k, 0.1 (k + 1))
        history.record(0.1 * k, np.zeros(2), np.array([float(k), 1.0]))
    motion = history.motion(0.25, 0.5)  # half of command 2, then 3 and 4 in full
    assert motion[:2] == pytest.approx([0.05 * 2 + 0.1 * 3 + 0.1 * 4, 0.25])
    assert history.motion(0.5, 0.5) == pytest.approx(np.zeros(6))
    history.reset()
    assert history.motion(0.0, 1.0) == pytest.approx(np.zeros(6))


def _panda(*sets: str):  # type: ignore[no-untyped-def]
    return build(apply_overrides(load_scenario("panda-4points"), list(sets)))


def test_a_measurement_without_stamp_or_of_now_is_used_as_is() -> None:
    exp = _panda()
    ctrl = exp.controller()
    s, inv_depth = exp.task.measure(exp.scene, exp.robot.fkine(exp.q0), 0.0)
    zero = np.zeros(exp.robot.n)
    a = ctrl.step(exp.q0, Measurement(s, inv_depth), 0.0, qdot_prev=zero)
    ctrl.reset()
    b = ctrl.step(exp.q0, Measurement(s, inv_depth, 0.0), 0.0, qdot_prev=zero)
    assert np.array_equal(a.qdot, b.qdot)
    with pytest.raises(ShapeError, match="before its image exists") as info:
        ctrl.step(exp.q0, Measurement(s, inv_depth, 0.5), 0.1, qdot_prev=zero)
    assert info.value.argument == "measurement.stamp"


def test_compensated_delayed_sensor_follows_the_undelayed_run() -> None:
    """A 25 Hz camera 100 ms late: compensated, the closed loop stays close to the undelayed
    one (trajectory and final error); uncompensated it strays much further."""
    base = ("control.lam=0.5", "simulation.max_iterations=200")
    delayed = ("sensor.rate=25.0", "sensor.latency=0.1")
    ref = _panda(*base).run().log
    comp = _panda(*base, *delayed).run().log
    raw = _panda(*base, *delayed, "sensor.compensate_latency=false").run().log
    n = min(len(ref.q), len(comp.q), len(raw.q))
    dev_comp = np.abs(comp.q[:n] - ref.q[:n]).max()
    dev_raw = np.abs(raw.q[:n] - ref.q[:n]).max()
    assert dev_comp < 0.5 * dev_raw, (dev_comp, dev_raw)
    assert dev_comp < 0.08
    assert comp.error_norm[-1] == pytest.approx(ref.error_norm[-1], rel=0.1, abs=2e-3)


def test_moment_features_are_compensated_at_the_measured_image_moments() -> None:
    """The moment features' interaction matrix needs the image moments, which only a
    measurement has: a compensated value far from it (a fast camera, a long latency) is
    linearised at the measured image instead of raising ConfigurationError."""
    exp = build(load_scenario("mc05-joint-limits"))
    ctrl = exp.controller()
    s, inv_depth = exp.task.measure(exp.scene, exp.robot.fkine(exp.q0), 0.0)
    fast = np.zeros(exp.robot.n)
    fast[0] = 5.0  # m/s along x for 0.04 s: the centroid moves ~0.3 normalized units
    ctrl.history.record(0.0, exp.q0, fast)
    step = ctrl.step(exp.q0, Measurement(s, inv_depth, 0.0), 0.04, qdot_prev=np.zeros(6))
    assert step.state is not None
    assert np.max(np.abs(step.state.s - s)) > 0.1  # brought far from the measured value
    assert np.all(np.isfinite(step.qdot))
