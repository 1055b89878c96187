"""The hardware servo loop against fake and simulated robots (issue 11, items 4 and 6).

Every test runs on a :class:`VirtualClock`, so it is fast and deterministic.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from redservo import ConfigurationError, JointLimits, make_law
from redservo.control import JointLimitForce, Occlusion, OcclusionAvoidance
from redservo.experiment.build import build
from redservo.features import PointFeature
from redservo.hardware import (
    ActuatorModel,
    FeatureMeasurement,
    FeatureSource,
    IdealFeatureSource,
    RobotInterface,
    ServoLoop,
    SimulatedRobot,
    Supervision,
    VirtualClock,
    guard_command,
)
from redservo.redundancy.flags import Flag
from redservo.robots import Afma6
from redservo.scenario import load_scenario
from redservo.scene import ConstantVelocity, PointSet, Scene, Sphere, Static
from redservo.sensors import NoPose
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

ROOT = Path(__file__).resolve().parents[1]
Q_MID = np.array([0.0, 0.0, 0.3, 0.0, 0.3, 0.0])
T = 0.04


class Spy:
    """A robot interface wrapper that records commands and stops and injects faults."""

    def __init__(
        self,
        inner: RobotInterface,
        *,
        fail_at: int | None = None,
        exc: BaseException | None = None,
        on_read: Callable[[int], None] | None = None,
        clock: Callable[[], float] | None = None,
    ) -> None:
        self.inner, self.fail_at, self.exc, self.on_read = inner, fail_at, exc, on_read
        self.clock = clock
        self.sent: list[np.ndarray] = []
        self.sent_at: list[float] = []  # loop time of each command (with ``clock``)
        self.stopped_at: list[float] = []
        self.stops = 0
        self.reads = 0

    def read_joints(self) -> tuple[float, np.ndarray]:
        if self.on_read is not None:
            self.on_read(self.reads)
        self.reads += 1
        return self.inner.read_joints()

    def send_velocity(self, qdot: np.ndarray) -> None:
        if self.fail_at is not None and len(self.sent) == self.fail_at:
            assert self.exc is not None
            raise self.exc
        self.sent.append(np.array(qdot))
        if self.clock is not None:
            self.sent_at.append(self.clock())
        self.inner.send_velocity(qdot)

    def stop(self) -> None:
        self.stops += 1
        if self.clock is not None:
            self.stopped_at.append(self.clock())
        self.inner.stop()


class Dropping:
    """A feature source that returns None on the calls where ``drop(call_index)`` is True."""

    def __init__(self, inner: FeatureSource, drop: Callable[[int], bool]) -> None:
        self.inner, self.drop, self.calls = inner, drop, 0

    def measure(self, t: float) -> FeatureMeasurement | None:
        i, self.calls = self.calls, self.calls + 1
        m = self.inner.measure(t)
        return None if self.drop(i) else m


def _setup(
    actuator: ActuatorModel | None = None,
) -> tuple[VirtualClock, Afma6, SimulatedRobot, Any, VisualTask]:
    """Afma6 at mid-range gazing at a point seen at (0.13, -0.08), 0.6 m away."""
    clock = VirtualClock(50.0)
    robot = Afma6()
    sim = SimulatedRobot(robot, actuator or ActuatorModel.ideal(), Q_MID, clock, period=T)
    wMo = robot.fkine(Q_MID) @ make_transform(t=(0.08, -0.05, 0.6))
    scene = Scene([PointSet("target", np.zeros((1, 3)), trajectory=Static(wMo))])
    task = VisualTask([TaskTerm(PointFeature(), "target")], [0.0, 0.0])
    return clock, robot, sim, IdealFeatureSource(task, scene, sim), task


def _loop(
    robot_iface: RobotInterface,
    source: FeatureSource,
    robot: Afma6,
    task: VisualTask,
    clock: VirtualClock,
    *,
    law: Any = None,
    limits: JointLimits | None = None,
    **kw: Any,
) -> ServoLoop:
    kw.setdefault("max_iterations", 400)
    return ServoLoop(
        robot_iface,
        source,
        robot,
        task,
        law or make_law("classical"),
        limits or robot.limits(),
        period=T,
        lam=1.0,
        clock=clock,
        sleep=clock.sleep,
        **kw,
    )


# -- nominal runs ------------------------------------------------------------------------------


def test_converges_on_an_ideal_robot_and_stops_it_once() -> None:
    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    res = _loop(spy, src, robot, task, clock).run()
    assert res.outcome == "converged"
    assert res.summary["final_error_norm"] < 1e-3
    assert spy.stops == 1 and res.overruns == 0
    assert res.measured.all() and len(res.log) == res.iterations
    # The simulator's log format, and t on the loop's clock since the start.
    np.testing.assert_allclose(res.log.t, np.arange(len(res.log)) * T, atol=1e-9)
    assert res.log.q.shape == (len(res.log), 6) and res.log.e1.shape == (len(res.log), 2)


def test_converges_with_a_lagging_delayed_robot() -> None:
    act = ActuatorModel(tau=0.1, delay_steps=2, qddot_max=5.0, encoder_resolution=1e-5, seed=0)
    clock, robot, sim, src, task = _setup(act)
    res = _loop(sim, src, robot, task, clock).run()
    assert res.outcome == "converged", res.reason
    assert res.iterations < 250


def test_ideal_loop_reproduces_the_simulator_bit_for_bit() -> None:
    exp = build(load_scenario("cm01-gaze"))
    sim_res = exp.run()
    clock = VirtualClock()
    dt = exp.options.dt
    sim = SimulatedRobot(exp.robot, ActuatorModel.ideal(), exp.q0, clock, period=dt)
    loop = ServoLoop(
        sim,
        IdealFeatureSource(exp.task, exp.scene, sim),
        exp.robot,
        exp.task,
        exp.law,
        exp.limits,
        period=dt,
        lam=exp.options.lam,
        max_iterations=exp.options.max_iterations,
        clock=clock,
        sleep=clock.sleep,
    )
    res = loop.run()
    assert res.outcome == sim_res.outcome == "converged"
    for name in ("q", "qdot", "s", "e1", "camera_twist", "constrained", "gamma"):
        assert np.array_equal(getattr(res.log, name), getattr(sim_res.log, name)), name


def test_save_writes_the_simulators_files(tmp_path: Path) -> None:
    clock, robot, sim, src, task = _setup()
    res = _loop(sim, src, robot, task, clock, max_iterations=5).run()
    assert res.outcome == "max_iterations"
    out = res.save(tmp_path / "run")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "max_iterations" and summary["iterations"] == 5
    assert summary["overruns"] == 0 and "max_cycle_time" in summary
    with np.load(out / "log.npz") as data:
        assert data["q"].shape == (5, 6)
    assert (out / "log.csv").read_text().startswith("t,q[0]")


# -- measurements: drops and the watchdog ------------------------------------------------------


@pytest.mark.parametrize("on_missing", ["hold", "zero"])
def test_short_dropout_is_bridged_and_the_loop_recovers(on_missing: str) -> None:
    clock, robot, sim, src, task = _setup()
    res = _loop(
        sim, Dropping(src, lambda i: 10 <= i < 14), robot, task, clock, on_missing=on_missing
    ).run()
    assert res.outcome == "converged"
    assert res.summary["held"] == 4 and res.summary["missing"] == 4
    assert not res.measured[10:14].any() and res.measured[14]
    held = res.log.qdot[10:14]
    if on_missing == "hold":
        assert np.array_equal(held, np.repeat(res.log.qdot[9:10], 4, axis=0))
    else:  # zero, reached at the robot's acceleration limit (Afma6: 1 m/s², 3 rad/s²)
        assert not held[-1].any()
        steps = np.abs(np.diff(res.log.qdot[9:14], axis=0))
        assert np.all(steps <= robot.limits().qddot_max * T + 1e-12)


def test_long_dropout_stops_on_the_watchdog() -> None:
    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    loop = _loop(spy, Dropping(src, lambda i: i >= 10), robot, task, clock, watchdog_timeout=0.3)
    res = loop.run()
    assert res.outcome == "stale_measurement" and "watchdog" in res.reason
    assert spy.stops == 1
    # Last fresh image at iteration 9 (t = 0.36 s): stale once older than 0.3 s, at t = 0.68 s.
    assert res.iterations == 18 and len(spy.sent) == 17


def test_old_measurements_are_not_used() -> None:
    class Late:
        def measure(self, t: float) -> FeatureMeasurement | None:
            m = src.measure(t)
            return None if m is None else m._replace(t_measured=t - 1.0)

    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    res = _loop(spy, Late(), robot, task, clock, watchdog_timeout=0.2).run()
    assert res.outcome == "stale_measurement" and len(res.log) == 0
    assert all(not c.any() for c in spy.sent) and spy.stops == 1


def test_frozen_joint_readings_stop_on_the_watchdog() -> None:
    class Frozen(Spy):
        def read_joints(self) -> tuple[float, np.ndarray]:
            t, q = super().read_joints()
            return (min(t, 50.0 + 4 * T), q)  # the driver stopped updating at t = 0.16 s

    clock, robot, sim, src, task = _setup()
    spy = Frozen(sim)
    res = _loop(spy, src, robot, task, clock, watchdog_timeout=0.2).run()
    assert res.outcome == "stale_measurement" and "joint readings" in res.reason
    assert res.iterations == 11 and spy.stops == 1  # stale once 0.2 s old: at t = 0.40 s


# -- faults ------------------------------------------------------------------------------------


def test_robot_exception_stops_then_reraises_with_the_iteration() -> None:
    clock, robot, sim, src, task = _setup()
    spy = Spy(sim, fail_at=5, exc=ConnectionError("link down"))
    loop = _loop(spy, src, robot, task, clock)
    with pytest.raises(ConnectionError, match="link down") as info:
        loop.run()
    note = " ".join(info.value.__notes__)
    assert "robot.send_velocity" in note and "iteration 5" in note
    assert spy.stops == 1
    assert loop.last_result is not None and loop.last_result.outcome == "error"
    assert len(loop.last_result.log) == 6  # the row of the failed send is logged


def test_law_exception_stops_then_reraises_or_returns() -> None:
    inner = make_law("classical")
    calls = []

    def law(**kw: Any) -> Any:
        calls.append(1)
        if len(calls) == 4:
            raise RuntimeError("solver diverged")
        return inner(**kw)

    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    with pytest.raises(RuntimeError, match="solver diverged") as info:
        _loop(spy, src, robot, task, clock, law=law).run()
    assert "in law at iteration 3" in " ".join(info.value.__notes__)
    assert spy.stops == 1
    calls.clear()
    res = _loop(spy, src, robot, task, clock, law=law).run(raise_errors=False)
    assert res.outcome == "error" and isinstance(res.error, RuntimeError)
    assert spy.stops == 2


def test_nan_from_the_law_sends_zero_and_stops() -> None:
    inner = make_law("classical")
    calls = []

    def law(**kw: Any) -> Any:
        calls.append(1)
        res = inner(**kw)
        return res._replace(qdot=res.qdot * np.nan) if len(calls) == 3 else res

    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    res = _loop(spy, src, robot, task, clock, law=law).run()
    assert res.outcome == "error" and "non-finite" in res.reason
    assert len(spy.sent) == 3 and not spy.sent[-1].any() and spy.stops == 1
    assert all(np.isfinite(c).all() for c in spy.sent)


def test_a_law_that_replaced_a_nan_command_also_stops_the_loop() -> None:
    from redservo.redundancy.base import Law, LawInputs, LawResult

    class Broken(Law):
        name = "broken"

        def compute(self, x: LawInputs) -> LawResult:
            return make_law("classical").compute(x)._replace(qdot=np.full(x.q.shape, np.nan))

    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    res = _loop(spy, src, robot, task, clock, law=Broken()).run()
    assert res.outcome == "error" and "non-finite" in res.reason
    assert len(spy.sent) == 1 and not spy.sent[0].any() and spy.stops == 1


def test_overruns_are_counted_and_the_loop_goes_on() -> None:
    clock, robot, sim, src, task = _setup()

    def slow(i: int) -> None:
        if i in (3, 7):
            clock.advance(2.5 * T)  # the joint read took 100 ms

    res = _loop(Spy(sim, on_read=slow), src, robot, task, clock, max_iterations=12).run()
    assert res.outcome == "max_iterations"
    assert res.overruns == 2 and res.summary["overruns"] == 2
    assert res.summary["max_cycle_time"] == pytest.approx(2.5 * T)
    # t is stamped after the (slow) read. After an overrun the next iteration starts at
    # once, then the period resumes from there.
    np.testing.assert_allclose(res.log.t[2:7] / T, [2.0, 5.5, 5.5, 6.5, 7.5])


def test_keyboard_interrupt_stops_cleanly() -> None:
    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    sleeps = []

    def sleep(d: float) -> None:
        sleeps.append(d)
        if len(sleeps) == 5:
            raise KeyboardInterrupt
        clock.sleep(d)

    loop = ServoLoop(
        spy, src, robot, task, make_law("classical"), robot.limits(),
        period=T, lam=1.0, clock=clock, sleep=sleep,
    )  # fmt: skip
    res = loop.run()
    assert res.outcome == "interrupted" and spy.stops == 1 and len(spy.sent) == 5


def test_request_stop_ends_the_run() -> None:
    clock, robot, sim, src, task = _setup()
    loop = _loop(sim, src, robot, task, clock)

    class Stopper:
        def measure(self, t: float) -> FeatureMeasurement | None:
            if clock() >= 50.0 + 6 * T - 1e-9:
                loop.request_stop()
            return src.measure(t)

    loop.source = Stopper()
    res = loop.run()
    assert res.outcome == "stopped" and res.iterations == 7


def test_duration_limit() -> None:
    clock, robot, sim, src, task = _setup()
    res = _loop(sim, src, robot, task, clock, max_iterations=None, duration=0.2).run()
    assert res.outcome == "max_iterations" and res.iterations == 5


# -- the command guard -------------------------------------------------------------------------


def test_commands_never_exceed_qdot_max_and_keep_their_direction() -> None:
    inner = make_law("classical")
    wanted: list[np.ndarray] = []

    def reckless(**kw: Any) -> Any:  # ignores the rate limits, and is 20 times too fast
        res = inner(**{**kw, "limits": kw["limits"].without_rates()})
        wanted.append(20.0 * res.qdot)
        return res._replace(qdot=wanted[-1])

    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    qdot_max = np.full(6, 0.02)
    limits = JointLimits(robot.q_min, robot.q_max, 0.1, qdot_max=qdot_max)
    res = _loop(spy, src, robot, task, clock, limits=limits, law=reckless).run()
    assert res.outcome == "converged"
    sent = np.array(spy.sent)
    assert np.all(np.abs(sent) <= qdot_max + 1e-15)
    assert res.summary["guarded"] > 0
    for w, c in zip(wanted, sent, strict=False):  # same direction
        assert float(w @ c) == pytest.approx(np.linalg.norm(w) * np.linalg.norm(c), rel=1e-9)


def test_guard_scales_velocity_and_acceleration_and_clips_position() -> None:
    lim = JointLimits([-1.0, -1.0], [1.0, 1.0], 0.1, qdot_max=1.0, qddot_max=10.0)
    z = np.zeros(2)
    cmd, rep = guard_command(np.array([4.0, -2.0]), q=z, qdot_prev=np.array([1.0, -0.5]), limits=lim, period=0.01)  # fmt: skip
    np.testing.assert_allclose(cmd, [1.0, -0.5])  # scaled by 1/4, direction kept
    assert rep.velocity_scale == 0.25 and rep.acceleration_scale == 1.0
    cmd, rep = guard_command(np.array([1.0, 0.5]), q=z, qdot_prev=z, limits=lim, period=0.01)
    np.testing.assert_allclose(cmd, [0.1, 0.05])  # the change is scaled to 10 rad/s² · 10 ms
    cmd, rep = guard_command(np.array([0.0, 0.5]), q=np.array([0.0, 0.999]), qdot_prev=np.array([0.0, 0.5]), limits=lim, period=0.01)  # fmt: skip
    np.testing.assert_allclose(cmd, [0.0, 0.1])
    assert rep.position_clipped == (1,) and rep.acceleration_exceeded == (1,)
    cmd, rep = guard_command(np.array([np.nan, 0.0]), q=z, qdot_prev=z, limits=lim, period=0.01)
    assert rep.non_finite and not cmd.any()


def test_guard_reports_an_acceleration_its_position_clip_exceeds() -> None:
    lim = JointLimits([-1.0, -1.0], [1.0, 1.0], 0.1, qdot_max=1.0, qddot_max=10.0)
    # Joint 1 cruises at 0.5 rad/s, 1 mm from its bound: the clip brings it to 0.1 rad/s in
    # one period, a change of 0.4 rad/s where q̈max·T allows 0.1.
    q, prev = np.array([0.0, 0.999]), np.array([0.05, 0.5])
    cmd, rep = guard_command(prev.copy(), q=q, qdot_prev=prev, limits=lim, period=0.01)
    np.testing.assert_allclose(cmd, [0.05, 0.1])
    assert rep.position_clipped == (1,) and rep.acceleration_exceeded == (1,)
    # A change landing exactly on q̈max·T (the acceleration scaling) is not an excess.
    cmd, rep = guard_command(np.array([1.0, 0.0]), q=np.zeros(2), qdot_prev=np.zeros(2), limits=lim, period=0.01)  # fmt: skip
    assert rep.acceleration_scale < 1.0 and rep.acceleration_exceeded == ()
    # A non-finite command replaced by zeros at speed is an excess too.
    cmd, rep = guard_command(np.array([np.nan, 0.0]), q=q, qdot_prev=prev, limits=lim, period=0.01)  # fmt: skip
    assert rep.non_finite and rep.acceleration_exceeded == (1,)
    no_rates = JointLimits([-1.0, -1.0], [1.0, 1.0], 0.1)
    assert guard_command(prev, q=q, qdot_prev=prev, limits=no_rates, period=0.01)[1].acceleration_exceeded == ()  # fmt: skip


def test_the_loop_counts_every_acceleration_the_guard_exceeds() -> None:
    inner = make_law("classical")

    def push(**kw: Any) -> Any:  # drives axis 0 into its bound at 0.18 m/s, whatever the task
        return inner(**kw)._replace(qdot=np.array([0.18, 0.0, 0.0, 0.0, 0.0, 0.0]))

    clock, robot, sim, src, task = _setup()
    limits = robot.limits().replace(margin_abs=0.05)
    spy = Spy(sim)
    # Planning over one period (max_hold = T) the guard clips at the bound; over the default
    # max_hold (the watchdog timeout) it brakes gradually and exceeds nothing.
    one_period = Supervision(max_hold=T)
    loop = _loop(
        spy,
        src,
        robot,
        task,
        clock,
        law=push,
        limits=limits,
        supervision=one_period,
        max_iterations=150,
    )
    res = loop.run()
    assert res.outcome == "max_iterations" and spy.stops == 1
    assert sim.fault is None and np.max(res.log.q[:, 0]) <= limits.safe_max[0] + 1e-12
    steps = np.abs(np.diff(np.vstack([np.zeros((1, 6)), res.log.qdot]), axis=0))
    over = np.any(steps > limits.qddot_max * T * (1 + 1e-9) + 1e-15, axis=1)
    assert over.sum() >= 1  # the clip at the bound
    assert res.summary["acceleration_exceeded"] == int(over.sum())
    assert res.summary["acceleration_exceeded"] == res.summary["acceleration_violations"]


def test_qdot_prev_is_passed_when_the_law_accepts_it() -> None:
    inner = make_law("classical")
    seen: list[np.ndarray] = []

    def law(*, qdot_prev: np.ndarray, **kw: Any) -> Any:
        seen.append(qdot_prev.copy())
        return inner(**kw)

    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    loop = _loop(spy, src, robot, task, clock, law=law, max_iterations=6)
    assert loop.passes_qdot_prev
    loop.run()
    assert not seen[0].any()
    for prev, sent in zip(seen[1:], spy.sent, strict=False):
        assert np.array_equal(prev, sent)
    assert _loop(spy, src, robot, task, clock).passes_qdot_prev  # the laws take it

    def plain(*, J1: Any, e1: Any, q: Any, limits: Any, lam: Any, dt: Any) -> Any:
        return inner(J1=J1, e1=e1, q=q, limits=limits, lam=lam, dt=dt)

    loop = _loop(spy, src, robot, task, clock, law=plain, max_iterations=3)
    assert not loop.passes_qdot_prev and loop.run().outcome == "max_iterations"


def test_invalid_settings_are_rejected() -> None:
    clock, robot, sim, src, task = _setup()
    with pytest.raises(ConfigurationError, match="period"):
        _loop(sim, src, robot, task, clock, watchdog_timeout=0.01)
    with pytest.raises(ConfigurationError, match="on_missing"):
        _loop(sim, src, robot, task, clock, on_missing="guess")
    with pytest.raises(ConfigurationError, match="max_iterations"):
        _loop(sim, src, robot, task, clock, max_iterations=0)


# -- the clock contract (issue 17, item 2) -----------------------------------------------------
#
# Every stamp is on the loop's clock. Each reproducer ends with robot.stop() called once,
# no command sent after the fault or the watchdog's deadline, and a bounded number of
# iterations. The virtual clock starts at 50 s, one tick every T = 40 ms.

T0 = 50.0


class Scripted:
    """A feature source whose i-th measurement is ``script(i, m)``, m being the true one."""

    def __init__(
        self, inner: FeatureSource, script: Callable[[int, FeatureMeasurement], Any]
    ) -> None:
        self.inner, self.script, self.calls = inner, script, 0

    def measure(self, t: float) -> FeatureMeasurement | None:
        i, self.calls = self.calls, self.calls + 1
        m = self.inner.measure(t)
        return None if m is None else self.script(i, m)


class Restamped(Spy):
    """Joint readings re-stamped (and possibly frozen) by ``stamp(k, t, q) -> (t, q)``."""

    def __init__(self, inner: RobotInterface, stamp: Callable[..., Any], **kw: Any) -> None:
        super().__init__(inner, **kw)
        self.stamp = stamp

    def read_joints(self) -> tuple[float, np.ndarray]:
        k = self.reads
        t, q = super().read_joints()
        return self.stamp(k, t, q)


def _frozen_after(n: int, replay: int | None = None) -> Callable[[int, Any], Any]:
    """A tracker that freezes after call ``n - 1``: it returns measurement ``replay`` (default
    the last good one, n - 1) forever."""
    seen: list[Any] = []

    def script(i: int, m: Any) -> Any:
        if i < n:
            seen.append(m)
            return m
        return seen[n - 1 if replay is None else replay]

    return script


def _run_spied(source_script: Any = None, stamp: Any = None, **kw: Any) -> tuple[Any, Spy]:
    clock, robot, sim, src, task = _setup()
    spy = Restamped(sim, stamp, clock=clock) if stamp else Spy(sim, clock=clock)
    source = Scripted(src, source_script) if source_script else src
    loop = _loop(spy, source, robot, task, clock, **kw)
    res = loop.run()
    assert spy.stops == 1, "robot.stop() must be called exactly once"
    assert loop.last_result is res
    return res, spy


def _no_command_after(spy: Spy, deadline: float) -> None:
    late = [t for t in spy.sent_at if t > deadline + 1e-9]
    assert not late, f"commands sent after the deadline {deadline}: {late}"


def test_an_epoch_stamped_camera_is_a_clock_fault_at_the_first_measurement() -> None:
    epoch = 1.7e9  # time.time() in 2023, while the loop runs on a monotonic clock

    res, spy = _run_spied(lambda i, m: m._replace(t_measured=epoch + m.t_measured))
    assert res.outcome == "clock_fault" and res.iterations == 1 and spy.sent == []
    assert res.clock_fault is not None
    assert (res.clock_fault.source, res.clock_fault.kind) == ("measurement", "future")
    assert "t_measured" in res.reason and "time.time()" in res.reason
    assert res.summary["clock_fault"]["kind"] == "future"


def test_an_inf_stamp_then_a_frozen_tracker_is_a_clock_fault() -> None:
    frozen = _frozen_after(11)

    def script(i: int, m: Any) -> Any:
        return m._replace(t_measured=np.inf) if i == 10 else frozen(i, m)

    res, spy = _run_spied(script)
    assert res.outcome == "clock_fault" and "iteration 10" in res.reason
    assert res.clock_fault is not None and res.clock_fault.kind == "non_finite"
    assert res.clock_fault.source == "measurement" and "inf" in res.reason
    assert len(spy.sent) == 10 and res.iterations == 11
    _no_command_after(spy, T0 + 9 * T)


def test_nan_measurement_stamps_are_a_clock_fault() -> None:
    res, spy = _run_spied(lambda i, m: m._replace(t_measured=float("nan")))
    assert res.outcome == "clock_fault" and spy.sent == [] and res.iterations == 1
    assert res.clock_fault is not None and res.clock_fault.kind == "non_finite"


def test_a_frozen_tracker_stops_the_arm_within_the_watchdog_time() -> None:
    res, spy = _run_spied(_frozen_after(10), watchdog_timeout=0.2)
    assert res.outcome == "stale_measurement" and "watchdog" in res.reason
    last_fresh = T0 + 9 * T  # call 9 is the last new image
    _no_command_after(spy, last_fresh + 0.2)
    assert spy.stopped_at[0] <= last_fresh + 0.2 + T + 1e-9  # the first tick past it
    assert res.iterations <= 16


def test_a_tracker_replaying_an_older_image_is_a_clock_fault() -> None:
    res, spy = _run_spied(_frozen_after(10, replay=5))
    assert res.outcome == "clock_fault" and res.clock_fault is not None
    assert res.clock_fault.kind == "backwards" and res.clock_fault.source == "measurement"
    assert len(spy.sent) == 10 and res.iterations == 11
    _no_command_after(spy, T0 + 9 * T)


def test_staleness_is_judged_on_arrival_too() -> None:
    # Stamps 45 ms ahead (within a 50 ms tolerance), then a frozen tracker: judged on its
    # stamps alone, the last image would stay "fresh" until 50.605 s and a command would be
    # sent at 50.60 s. Judged on its arrival (50.36 s), nothing is sent after 50.56 s.
    frozen = _frozen_after(10)
    res, spy = _run_spied(
        lambda i, m: frozen(i, m._replace(t_measured=m.t_measured + 0.045)),
        watchdog_timeout=0.2,
        clock_tolerance=0.05,
    )
    assert res.outcome == "stale_measurement"
    _no_command_after(spy, T0 + 9 * T + 0.2)


@pytest.mark.parametrize(
    ("stamp", "kind"),
    [
        (lambda k, t, q: (float("nan"), q), "non_finite"),
        (lambda k, t, q: (None, q), "non_finite"),
        (lambda k, t, q: (1.7e9 + t, q), "future"),
    ],
    ids=["nan", "none", "epoch"],
)
def test_a_broken_joint_stamp_is_a_clock_fault(stamp: Any, kind: str) -> None:
    res, spy = _run_spied(stamp=stamp)
    assert res.outcome == "clock_fault" and spy.sent == [] and res.iterations == 1
    assert res.clock_fault is not None
    assert (res.clock_fault.source, res.clock_fault.kind) == ("joints", kind)
    assert "read_joints" in res.reason
    if stamp(0, T0, Q_MID)[0] is None:
        assert "is None, not a finite number" in res.reason


def test_joint_stamps_alternating_0_1_on_frozen_joints_are_a_clock_fault() -> None:
    first: list[np.ndarray] = []

    def stamp(k: int, t: float, q: np.ndarray) -> tuple[float, np.ndarray]:
        first.append(q) if not first else None
        return float(k % 2), first[0]  # q frozen, the stamp flips between 0 and 1

    res, spy = _run_spied(stamp=stamp)
    assert res.outcome == "clock_fault" and res.iterations == 3
    assert res.clock_fault is not None
    assert (res.clock_fault.source, res.clock_fault.kind) == ("joints", "backwards")
    # Stamps 49 s old were never fresh: the arm was only ever told to keep still.
    assert all(not c.any() for c in spy.sent) and len(res.log) == 0
    _no_command_after(spy, T0 + T)


def test_joint_stamps_going_back_near_now_stop_the_arm_at_once() -> None:
    q_frozen: list[np.ndarray] = []

    def stamp(k: int, t: float, q: np.ndarray) -> tuple[float, np.ndarray]:
        q_frozen.append(q) if not q_frozen else None
        return T0 + 0.001 * (k % 2), q_frozen[0]

    res, spy = _run_spied(stamp=stamp)
    assert res.outcome == "clock_fault" and res.iterations == 3 and len(spy.sent) == 2
    assert res.clock_fault is not None and res.clock_fault.kind == "backwards"
    _no_command_after(spy, T0 + T)


def test_old_joint_stamps_are_not_fresh_and_stop_on_the_watchdog() -> None:
    res, spy = _run_spied(stamp=lambda k, t, q: (t - 1.0, q), watchdog_timeout=0.2)
    assert res.outcome == "stale_measurement" and "joint readings" in res.reason
    assert "monotonic clock" in res.reason  # the hint: never fresh, stamps far behind
    assert all(not c.any() for c in spy.sent) and res.iterations <= 7


def test_a_clock_fault_run_saves_and_loads(tmp_path: Path) -> None:
    from redservo import load_run

    res, _ = _run_spied(lambda i, m: m._replace(t_measured=np.inf) if i == 3 else m)
    out = res.save(tmp_path / "run")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "clock_fault" and summary["iterations"] == 3
    assert summary["clock_fault"] == {
        "source": "measurement",
        "kind": "non_finite",
        "stamp": "inf",
        "reference": "nan",
        "tolerance": 0.005,
        "given": "",
    }
    assert load_run(out).outcome == "clock_fault"


def test_clock_tolerance_is_validated() -> None:
    clock, robot, sim, src, task = _setup()
    for bad in (-0.001, float("nan"), 0.5):
        with pytest.raises(ConfigurationError, match="clock_tolerance"):
            _loop(sim, src, robot, task, clock, clock_tolerance=bad)
    assert _loop(sim, src, robot, task, clock, clock_tolerance=0.0).run().outcome == "converged"


# -- any exception keeps the partial log (issue 17, item 6) ---------------------------------------


class _Custom(BaseException):
    pass


@pytest.mark.parametrize("exc", [SystemExit(3), GeneratorExit(), _Custom("abort")])
@pytest.mark.parametrize("raise_errors", [True, False])
def test_a_base_exception_keeps_the_partial_log_and_propagates(
    exc: BaseException, raise_errors: bool
) -> None:
    clock, robot, sim, src, task = _setup()

    def fail(i: int) -> None:
        if i == 5:
            raise exc

    spy = Spy(sim, on_read=fail, clock=clock)
    loop = _loop(spy, src, robot, task, clock)
    with pytest.raises(type(exc)) as info:
        loop.run(raise_errors=raise_errors)
    assert info.value is exc and spy.stops == 1 and len(spy.sent) == 5
    res = loop.last_result
    assert res is not None and res.outcome == "interrupted" and res.error is exc
    assert f"{type(exc).__name__} in robot.read_joints at iteration 5" in res.reason
    assert len(res.log) == 5 and res.summary["iterations"] == 5
    assert "robot.stop() was called" in " ".join(exc.__notes__)


def test_system_exit_from_stop_propagates_after_the_result_is_kept() -> None:
    clock, robot, sim, src, task = _setup()

    class Refusing(Spy):
        def stop(self) -> None:
            super().stop()
            raise SystemExit("driver shut down")

    spy = Refusing(sim)
    loop = _loop(spy, src, robot, task, clock, max_iterations=4)
    with pytest.raises(SystemExit):
        loop.run()
    res = loop.last_result
    assert res is not None and res.outcome == "interrupted" and len(res.log) == 4
    assert "robot.stop() raised SystemExit" in res.reason and spy.stops == 1


# -- the example ---------------------------------------------------------------------------------


def test_real_robot_example_runs(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "real_robot.py"), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    assert "converged" in proc.stdout
    assert (tmp_path / "summary.json").is_file()


# -- the Controller in the servo loop: objectives and feed-forward (issue 18, item 1) -----------


def _servo_like_simulate(exp: Any, law: Any, **kw: Any) -> Any:
    """The servo loop on an ideal simulated robot, set up as ``exp``'s simulation."""
    clock = VirtualClock()
    dt = exp.options.dt
    sim = SimulatedRobot(exp.robot, ActuatorModel.ideal(), exp.q0, clock, period=dt)
    loop = ServoLoop(
        sim,
        IdealFeatureSource(exp.task, exp.scene, sim),
        exp.robot,
        exp.task,
        law,
        exp.limits,
        period=dt,
        lam=exp.options.lam,
        max_iterations=exp.options.max_iterations,
        clock=clock,
        sleep=clock.sleep,
        **kw,
    )
    return loop.run()


def test_an_objective_reaches_the_law_and_matches_the_simulator_bit_for_bit() -> None:
    from redservo.redundancy.costs import joint_limit_force
    from redservo.simulation import simulate

    exp = build(load_scenario("cm01-gaze"))
    inner = exp.law
    seen: list[tuple[np.ndarray, np.ndarray]] = []

    def law(**kw: Any) -> Any:
        seen.append((kw["q"].copy(), kw["secondary"]))
        return inner(**kw)

    force = JointLimitForce(kappa=0.3)
    sim_res = simulate(
        exp.robot, exp.scene, exp.task, inner, exp.q0, options=exp.options, limits=exp.limits,
        objectives=[force],
    )  # fmt: skip
    res = _servo_like_simulate(exp, law, objectives=[force])
    assert res.outcome == sim_res.outcome == "converged" and len(res.log) == len(sim_res.log)
    for name in ("q", "qdot", "s", "e1", "camera_twist", "constrained", "gamma"):
        assert np.array_equal(getattr(res.log, name), getattr(sim_res.log, name)), name
    # The objective's command is what the law received, at every step.
    assert len(seen) == len(res.log)
    for q, secondary in seen:
        assert np.array_equal(secondary, joint_limit_force(q, exp.limits, kappa=0.3))
    # ... and it changed the commands: without it the run differs.
    plain = simulate(
        exp.robot, exp.scene, exp.task, inner, exp.q0, options=exp.options, limits=exp.limits
    )
    n = min(len(plain.log), len(res.log))
    assert not np.array_equal(plain.log.qdot[:n], res.log.qdot[:n])


def test_estimated_feedforward_reduces_the_tracking_error_of_a_moving_target() -> None:
    robot = Afma6()
    errs = {}
    for ff in ("none", "estimated"):
        clock = VirtualClock(50.0)
        sim = SimulatedRobot(robot, ActuatorModel.ideal(), Q_MID, clock, period=T)
        wMo = robot.fkine(Q_MID) @ make_transform(t=(0.0, 0.0, 1.0))
        traj = ConstantVelocity(wMo, v=np.array([0.0, 0.05, 0.0]))
        scene = Scene([PointSet("target", np.zeros((1, 3)), trajectory=traj)])
        task = VisualTask([TaskTerm(PointFeature(), "target")], [0.0, 0.0])
        src = IdealFeatureSource(task, scene, sim)
        res = _loop(
            sim, src, robot, task, clock, law=make_law("iterative-smooth"), feedforward=ff,
            max_iterations=150, stop_at_convergence=False,
        ).run()  # fmt: skip
        assert res.outcome == "max_iterations" and len(res.log) == 150
        errs[ff] = float(np.mean(res.log.error_norm[50:]))
    assert errs["estimated"] < 0.5 * errs["none"], errs


def test_an_objective_that_ends_the_run_stops_the_arm() -> None:
    calls: list[float] = []

    def stop_at_five(ctx: Any) -> tuple[None, str | None]:
        calls.append(ctx.t)
        assert ctx.scene is None and ctx.bMc is None  # no scene on a real arm
        return None, ("occluded" if len(calls) == 5 else None)

    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    res = _loop(spy, src, robot, task, clock, objectives=[stop_at_five]).run()
    assert res.outcome == "objective_stop" and "occluded" in res.reason
    assert "iteration 4" in res.reason and len(spy.sent) == 4 and spy.stops == 1
    assert len(res.log) == 4  # the stopped iteration sends nothing and logs nothing
    np.testing.assert_allclose(calls, np.arange(5) * T, atol=1e-9)  # measurement times


def test_an_objective_exception_names_its_stage() -> None:
    def broken(ctx: Any) -> Any:
        raise RuntimeError("cost diverged")

    clock, robot, sim, src, task = _setup()
    spy = Spy(sim)
    with pytest.raises(RuntimeError, match="cost diverged") as info:
        _loop(spy, src, robot, task, clock, objectives=[broken]).run()
    assert "in objectives at iteration 0" in " ".join(info.value.__notes__)
    assert spy.stops == 1 and not spy.sent


def test_occlusion_needs_a_scene_and_known_feedforward_is_refused() -> None:
    clock, robot, sim, src, task = _setup()
    occ = Occlusion(occluder="ball", target="target")
    with pytest.raises(ConfigurationError, match="needs the scene") as info:
        _loop(sim, src, robot, task, clock, objectives=[JointLimitForce(), OcclusionAvoidance(occ)])
    assert info.value.argument == "objectives[1]"
    with pytest.raises(ConfigurationError, match="only the simulator") as info:
        _loop(sim, src, robot, task, clock, feedforward="known")
    assert info.value.argument == "feedforward"

    def plain(*, J1: Any, e1: Any, q: Any, limits: Any, lam: Any, dt: Any) -> Any:
        return make_law("classical")(J1=J1, e1=e1, q=q, limits=limits, lam=lam, dt=dt)

    with pytest.raises(ConfigurationError, match="secondary") as info:
        _loop(sim, src, robot, task, clock, law=plain, objectives=[JointLimitForce()])
    assert info.value.argument == "objectives"
    with pytest.raises(ConfigurationError, match="de1_dt") as info:
        _loop(sim, src, robot, task, clock, law=plain, feedforward="estimated")
    assert info.value.argument == "feedforward"


def test_occlusion_with_its_own_scene_runs_in_the_servo_loop() -> None:
    """Given the scene, the occlusion objective uses the model robot's fkine(q) as the camera
    pose: a sphere parked on the line of sight ends the run at once."""
    clock = VirtualClock(50.0)
    robot = Afma6()
    sim = SimulatedRobot(robot, ActuatorModel.ideal(), Q_MID, clock, period=T)
    bMc = robot.fkine(Q_MID)
    pts = np.array([[0.03, 0.0, 0.0], [-0.03, 0.02, 0.0], [0.0, -0.03, 0.0]])
    scene = Scene(
        [
            PointSet("target", pts, trajectory=Static(bMc @ make_transform(t=(0, 0, 1.0)))),
            Sphere("ball", 0.05, trajectory=Static(bMc @ make_transform(t=(0, 0, 0.5)))),
        ]
    )
    task = VisualTask([TaskTerm(PointFeature(p), "target") for p in pts], np.zeros(6))
    src = IdealFeatureSource(task, scene, sim)
    occ = OcclusionAvoidance(Occlusion(occluder="ball", target="target"), scene=scene)
    res = _loop(sim, src, robot, task, clock, objectives=[occ]).run()
    assert res.outcome == "objective_stop" and "occluded" in res.reason


def test_each_run_resets_the_controller() -> None:
    clock, robot, sim, src, task = _setup()
    loop = _loop(sim, src, robot, task, clock, feedforward="estimated", max_iterations=5)
    first = loop.run()
    clock2, _, sim2, src2, _ = _setup()
    loop.robot, loop.source, loop.clock, loop.sleep = sim2, src2, clock2, clock2.sleep
    second = loop.run()  # the same loop again, from the same start: the same commands
    assert np.array_equal(first.log.qdot, second.log.qdot)


class NoPoseSource:
    """A feature source whose PnP gave no pose on the calls in ``misses`` (frames in a row)."""

    def __init__(self, inner: FeatureSource, misses: dict[int, int]) -> None:
        self.inner, self.misses, self.calls = inner, misses, 0

    def measure(self, t: float) -> FeatureMeasurement | None:
        i, self.calls = self.calls, self.calls + 1
        m = self.inner.measure(t)
        if m is None or i not in self.misses:
            return m
        return m._replace(no_pose=NoPose(self.misses[i], "target", 3, 4))


def test_a_measurement_without_a_pose_is_the_no_pose_flag_of_its_step() -> None:
    """A source's image without a PnP pose (``FeatureMeasurement.no_pose``) reaches the
    servo run's log and summary as the typed flag ``no-pose`` (value: images in a row), as
    in the simulation; the other steps carry none."""
    clock, robot, sim, source, task = _setup()
    src = NoPoseSource(source, {5: 1, 6: 2, 7: 3})
    res = _loop(sim, src, robot, task, clock, max_iterations=20).run()
    column = res.log.flag(Flag.NO_POSE)  # NaN where not raised
    raised = np.flatnonzero(np.isfinite(column))
    assert list(column[raised]) == [1.0, 2.0, 3.0]
    assert np.all(np.diff(raised) == 1)  # the steps of the three measurements in a row
    assert res.summary["flags"]["no-pose"]["count"] == 3
