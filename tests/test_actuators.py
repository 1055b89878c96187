"""The actuator model and the simulated robot behind the hardware interface (issue 11, item 5)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from redservo import ConfigurationError, JointLimitError, ShapeError
from redservo.features import PointFeature
from redservo.hardware import (
    ActuatorModel,
    IdealFeatureSource,
    RobotInterface,
    SimulatedRobot,
    VirtualClock,
)
from redservo.robots import Afma6
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask


def _run(model: ActuatorModel, cmd: np.ndarray, steps: int, dt: float) -> tuple:
    """Hold ``cmd`` for ``steps`` periods from rest at 0; return (q, v) histories (steps+1, n)."""
    n = cmd.shape[0]
    model.reset(np.zeros(n))
    q = np.zeros(n)
    qs, vs = [q], [np.zeros(n)]
    for _ in range(steps):
        q, v = model.step(q, cmd, dt)
        qs.append(q)
        vs.append(v)
    return np.array(qs), np.array(vs)


def test_first_order_lag_reaches_63_percent_at_tau() -> None:
    tau, dt = 0.1, 0.001
    qs, vs = _run(ActuatorModel(tau=tau), np.array([1.0, -2.0]), 300, dt)
    k = round(tau / dt)
    np.testing.assert_allclose(vs[k], (1.0 - math.exp(-1.0)) * np.array([1.0, -2.0]), rtol=1e-12)
    # The step response is exact at every sample: v = u (1 - e^{-t/τ}),
    # q = u (t - τ (1 - e^{-t/τ})) (the mean velocity over each period is integrated exactly).
    t = np.arange(301) * dt
    np.testing.assert_allclose(vs[:, 0], 1.0 - np.exp(-t / tau), atol=1e-12)
    np.testing.assert_allclose(qs[:, 0], t - tau * (1.0 - np.exp(-t / tau)), atol=1e-12)


def test_per_joint_time_constants() -> None:
    _, vs = _run(ActuatorModel(tau=[0.05, 0.0, 0.2]), np.ones(3), 50, 0.001)
    np.testing.assert_allclose(vs[50], [1 - math.exp(-1), 1.0, 1 - math.exp(-0.25)], rtol=1e-12)
    assert vs[1, 1] == 1.0  # τ = 0: no lag on that axis


@pytest.mark.parametrize("k", [1, 3])
def test_transport_delay_is_exactly_k_periods(k: int) -> None:
    dt = 0.04
    cmds = np.array([[0.3, -0.1], [0.5, 0.2], [-0.4, 0.0], [0.1, 0.1], [0.0, 0.7]] + [[0, 0]] * 4)
    for tau in (0.0, 0.07):
        ref, dly = ActuatorModel(tau=tau), ActuatorModel(tau=tau, delay_steps=k)
        ref.reset(np.zeros(2))
        dly.reset(np.zeros(2))
        q_ref, q_dly = np.zeros(2), np.zeros(2)
        v_ref_hist, v_dly_hist = [], []
        for u in cmds:
            q_ref, v_ref = ref.step(q_ref, u, dt)
            q_dly, v_dly = dly.step(q_dly, u, dt)
            v_ref_hist.append(v_ref)
            v_dly_hist.append(v_dly)
        v_ref_a, v_dly_a = np.array(v_ref_hist), np.array(v_dly_hist)
        assert np.all(v_dly_a[:k] == 0.0)
        np.testing.assert_array_equal(v_dly_a[k:], v_ref_a[:-k])


def test_velocity_saturation_clips_each_axis() -> None:
    _, vs = _run(ActuatorModel(qdot_max=[1.0, 1.0, 0.5]), np.array([2.0, -3.0, 0.1]), 2, 0.01)
    np.testing.assert_array_equal(vs[1], [1.0, -1.0, 0.1])


def test_acceleration_saturation_ramps_the_velocity() -> None:
    a_max, dt = 2.0, 0.01
    qs, vs = _run(ActuatorModel(qddot_max=a_max), np.array([1.0, -0.01]), 80, dt)
    dv = np.diff(vs, axis=0)
    assert np.all(np.abs(dv) <= a_max * dt + 1e-15)
    # Axis 0 ramps at a_max to 1 rad/s in 0.5 s (50 steps); axis 1's step is within one period.
    np.testing.assert_allclose(vs[25, 0], 0.5, rtol=1e-12)
    assert vs[50, 0] == pytest.approx(1.0) and vs[1, 1] == -0.01
    # Constant-acceleration ramp: q = a t² / 2 while ramping.
    np.testing.assert_allclose(qs[25, 0], 0.5 * a_max * 0.25**2, rtol=1e-12)


def test_acceleration_limit_also_bounds_the_lag_response() -> None:
    _, vs = _run(ActuatorModel(tau=0.01, qddot_max=5.0), np.array([1.0]), 100, 0.002)
    assert np.max(np.abs(np.diff(vs[:, 0]))) <= 5.0 * 0.002 + 1e-15


def test_encoder_quantizes_to_the_resolution() -> None:
    res = np.array([1e-4, 2.5e-3])
    model = ActuatorModel(encoder_resolution=res)
    model.reset(np.zeros(2))
    rng = np.random.default_rng(0)
    for q in rng.uniform(-2, 2, (200, 2)):
        r = model.encoder(q)
        ticks = r / res
        np.testing.assert_allclose(ticks, np.round(ticks), atol=1e-6)
        assert np.all(np.abs(r - q) <= res / 2 + 1e-12)


def test_encoder_noise_has_the_given_std_and_is_seeded() -> None:
    model = ActuatorModel(encoder_noise_std=1e-3, seed=7)
    model.reset(np.zeros(1))
    readings = np.array([model.encoder([0.5])[0] for _ in range(4000)])
    assert np.std(readings - 0.5) == pytest.approx(1e-3, rel=0.05)
    model.reset(np.zeros(1))  # re-seeded: the same sequence again
    assert model.encoder([0.5])[0] == readings[0]


def test_ideal_model_is_perfect_integration_bit_for_bit() -> None:
    model = ActuatorModel.ideal()
    assert model.is_ideal
    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, 6)
    model.reset(q)
    for _ in range(50):
        qdot, dt = rng.normal(0, 0.5, 6), float(rng.uniform(0.001, 0.1))
        expected = q + qdot * dt
        q, v = model.step(q, qdot, dt)
        assert np.array_equal(q, expected) and np.array_equal(v, qdot)
        assert np.array_equal(model.encoder(q), q)
    assert not ActuatorModel(tau=0.01).is_ideal


def test_invalid_parameters_name_the_argument() -> None:
    with pytest.raises(ConfigurationError, match="tau"):
        ActuatorModel(tau=-0.1)
    with pytest.raises(ConfigurationError, match="delay_steps"):
        ActuatorModel(delay_steps=1.5)  # type: ignore[arg-type]
    with pytest.raises(ConfigurationError, match="qdot_max"):
        ActuatorModel(qdot_max=[1.0, 0.0])
    with pytest.raises(ConfigurationError, match="encoder_resolution"):
        ActuatorModel(encoder_resolution=float("nan"))
    with pytest.raises(ShapeError, match="tau has 2 values but the robot has 3"):
        ActuatorModel(tau=[0.1, 0.2]).reset(np.zeros(3))
    with pytest.raises(ShapeError, match="reset"):
        ActuatorModel().step(np.zeros(2), np.zeros(2), 0.01)


def test_from_table_reads_an_actuators_section() -> None:
    model = ActuatorModel.from_table({"tau": [0.02, 0.03], "delay_steps": 2, "seed": 4})
    assert model.delay_steps == 2 and model.tau is not None and model.tau.tolist() == [0.02, 0.03]
    with pytest.raises(ConfigurationError, match=r"actuators\.lag"):
        ActuatorModel.from_table({"lag": 0.1})
    with pytest.raises(ConfigurationError, match=r"actuators\.qddot_max"):
        ActuatorModel.from_table({"qddot_max": -1.0})


# -- the simulated robot -----------------------------------------------------------------------

Q_MID = np.array([0.0, 0.0, 0.3, 0.0, 0.3, 0.0])


def test_simulated_robot_implements_the_interface_and_follows_the_clock() -> None:
    clock = VirtualClock(100.0)
    sim = SimulatedRobot(Afma6(), ActuatorModel(delay_steps=1), Q_MID, clock, period=0.04)
    assert isinstance(sim, RobotInterface)
    cmd = np.array([0.1, 0, 0, 0, 0, 0])
    sim.send_velocity(cmd)
    clock.sleep(0.04)
    t, q = sim.read_joints()
    assert t == pytest.approx(100.04) and np.array_equal(q, Q_MID)  # delayed by one period
    clock.sleep(0.08)
    _, q = sim.read_joints()
    assert q[0] == pytest.approx(0.1 * 0.08)
    sim.stop()
    clock.sleep(0.2)
    _, q2 = sim.read_joints()
    assert q2[0] == pytest.approx(0.1 * 0.08)  # a stop skips the delay line


def test_simulated_robot_faults_on_a_joint_limit() -> None:
    clock = VirtualClock()
    robot = Afma6()
    q0 = Q_MID.copy()
    q0[0] = robot.q_max[0] - 0.001
    sim = SimulatedRobot(robot, ActuatorModel.ideal(), q0, clock, period=0.01)
    sim.send_velocity(np.array([0.5, 0, 0, 0, 0, 0]))
    clock.sleep(0.05)
    _, q = sim.read_joints()
    assert q[0] == robot.q_max[0]
    with pytest.raises(JointLimitError, match="joint 0"):
        sim.send_velocity(np.zeros(6))
    sim.stop()  # always allowed


def test_ideal_feature_source_measures_the_true_pose_and_reports_loss() -> None:
    clock = VirtualClock()
    robot = Afma6()
    sim = SimulatedRobot(robot, ActuatorModel.ideal(), Q_MID, clock, period=0.04)
    wMo = robot.fkine(Q_MID) @ make_transform(t=(0.1, -0.05, 0.5))
    scene = Scene([PointSet("target", np.zeros((1, 3)), trajectory=Static(wMo))])
    task = VisualTask([TaskTerm(PointFeature(), "target")], [0.0, 0.0])
    src = IdealFeatureSource(task, scene, sim)
    m = src.measure(clock())
    assert m is not None
    np.testing.assert_allclose(m.s, [0.2, -0.1])
    np.testing.assert_allclose(m.inv_depth[0], [2.0])
    behind = Scene(
        [
            PointSet(
                "target", np.zeros((1, 3)), trajectory=Static(wMo @ make_transform(t=(0, 0, -1)))
            )
        ]
    )
    assert IdealFeatureSource(task, behind, sim).measure(clock()) is None
