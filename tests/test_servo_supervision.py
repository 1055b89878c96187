"""The servo loop on a real clock (issue 32): a late loop, a blocking driver and a robot that
does not follow stop the arm before a hard limit.

Every test runs on a :class:`VirtualClock` (a slow law or driver advances it), so nothing
depends on the machine's speed.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from redservo import ConfigurationError, JointLimits, make_law
from redservo.features import PointFeature
from redservo.hardware import (
    ActuatorModel,
    IdealFeatureSource,
    ServoLoop,
    SimulatedRobot,
    Supervision,
    VirtualClock,
    guard_command,
)
from redservo.robots import Afma6
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

ROOT = Path(__file__).resolve().parents[1]
T = 0.04


def _bench() -> Any:
    spec = importlib.util.spec_from_file_location("late_loop", ROOT / "benchmarks/late_loop.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class Driver:
    """A robot interface around a simulated robot: optionally frozen encoder, ignored
    commands, or a ``send_velocity`` that blocks (advances the clock)."""

    def __init__(self, sim: SimulatedRobot, clock: VirtualClock) -> None:
        self.sim, self.clock = sim, clock
        self.freeze_at: int | None = None  # read index from which q is frozen (fresh stamps)
        self.ignore = False  # drop every command
        self.block: dict[int, float] = {}  # send index -> seconds it blocks
        self.reads = self.sends = self.stops = 0
        self.sent_at: list[float] = []
        self._frozen: np.ndarray | None = None

    def read_joints(self) -> tuple[float, np.ndarray]:
        t, q = self.sim.read_joints()
        if self.freeze_at is not None and self.reads >= self.freeze_at:
            self._frozen = q if self._frozen is None else self._frozen
            q = self._frozen
        self.reads += 1
        return t, q

    def send_velocity(self, qdot: np.ndarray) -> None:
        self.clock.advance(self.block.get(self.sends, 0.0))
        self.sends += 1
        self.sent_at.append(self.clock())
        self.sim.send_velocity(np.zeros_like(qdot) if self.ignore else qdot)

    def stop(self) -> None:
        self.stops += 1
        self.sim.stop()


def _outward(clock: VirtualClock, seconds: float = 0.0, joint: int | None = 0) -> Any:
    """A law pushing joint ``joint`` (all when None) at full speed toward its upper limit,
    taking ``seconds`` per call."""
    inner = make_law("classical")

    def law(**kw: Any) -> Any:
        clock.advance(seconds)
        vmax = kw["limits"].qdot_max
        qdot = vmax.copy() if joint is None else np.eye(len(vmax))[joint] * vmax[joint]
        return inner(**kw)._replace(qdot=qdot)

    return law


def _setup(
    q0: np.ndarray, act: ActuatorModel | None = None
) -> tuple[VirtualClock, Afma6, SimulatedRobot, Driver, Any, VisualTask]:
    clock = VirtualClock(20.0)
    robot = Afma6()
    sim = SimulatedRobot(robot, act or ActuatorModel.ideal(), q0, clock, period=T)
    wMo = robot.fkine(q0) @ make_transform(t=(0.05, -0.03, 0.6))
    scene = Scene([PointSet("target", np.zeros((1, 3)), trajectory=Static(wMo))])
    task = VisualTask([TaskTerm(PointFeature(), "target")], [0.0, 0.0])
    return clock, robot, sim, Driver(sim, clock), IdealFeatureSource(task, scene, sim), task


def _run(
    drv: Driver, src: Any, robot: Afma6, task: VisualTask, clock: VirtualClock, law: Any, **kw: Any
) -> Any:
    kw.setdefault("max_iterations", 300)
    kw.setdefault("limits", robot.limits().replace(margin_abs=0.02))
    loop = ServoLoop(
        drv,
        src,
        robot,
        task,
        law,
        period=T,
        lam=1.0,
        stop_at_convergence=False,
        clock=clock,
        sleep=clock.sleep,
        **kw,
    )
    return loop.run(raise_errors=False)


Q_NEAR = np.array([0.6, 0.0, 0.3, 0.0, 0.3, 0.0])  # joint 0 is 0.08 m below its upper limit


# -- a late loop ---------------------------------------------------------------------------------


def test_a_law_taking_up_to_5_periods_never_reaches_a_hard_limit_in_10_random_runs() -> None:
    bench = _bench()
    for seed in range(10):
        for sup in bench.CONFIGS.values():
            contact, outcome, deepest = bench.late_run(seed, sup, iterations=60)
            assert not contact and deepest > 0.0, (seed, sup, outcome)


def test_the_guard_plans_over_the_hold_time() -> None:
    lim = JointLimits([-1.0], [1.0], 0.1, qdot_max=2.0, margin_abs=0.1)
    q = np.array([0.5])  # 0.4 below the safe bound 0.9
    cmd, rep = guard_command(
        np.array([2.0]), q=q, qdot_prev=np.array([2.0]), limits=lim, period=0.01
    )
    assert cmd[0] == pytest.approx(2.0) and rep.position_clipped == ()  # one period: no clip
    cmd, rep = guard_command(
        np.array([2.0]), q=q, qdot_prev=np.array([2.0]), limits=lim, period=0.01, hold=0.5
    )
    assert cmd[0] == pytest.approx(0.8) and rep.position_clipped == (0,)  # q + v·0.5 = 0.9
    cmd, _ = guard_command(
        np.array([-2.0]), q=q, qdot_prev=np.array([-2.0]), limits=lim, period=0.01, hold=0.5
    )
    assert cmd[0] == pytest.approx(-2.0)  # inward: untouched


def test_53_cycles_longer_than_the_watchdog_stop_at_the_first() -> None:
    clock, robot, sim, drv, src, task = _setup(Q_NEAR)
    law = _outward(clock, seconds=0.33, joint=None)
    res = _run(drv, src, robot, task, clock, law, watchdog_timeout=0.24, max_iterations=53)
    assert res.outcome == "late" and "max_hold 0.24" in res.reason, res.reason
    assert drv.stops == 1 and sim.fault is None
    assert res.iterations <= 2 and drv.sends <= 2  # the late command is never sent


def test_consecutive_overruns_below_the_hold_bound_stop_after_max_overruns() -> None:
    clock, robot, _, drv, src, task = _setup(Q_NEAR)
    law = _outward(clock, seconds=1.5 * T, joint=None)
    sup = Supervision(max_overruns=3)
    res = _run(drv, src, robot, task, clock, law, supervision=sup)
    assert res.outcome == "late" and "3 consecutive overruns" in res.reason, res.reason
    assert res.overruns == 3 and drv.stops == 1


def test_a_send_velocity_blocking_1_s_stops_the_run() -> None:
    clock, robot, sim, drv, src, task = _setup(Q_NEAR)
    drv.block = {6: 1.0}
    res = _run(drv, src, robot, task, clock, _outward(clock, joint=3))
    assert res.outcome == "late" and "1.000 s ago" in res.reason, res.reason
    assert drv.sends == 7 and drv.stops == 1  # nothing sent after the blocking call, then stop()
    assert sim.fault is None


# -- a robot that does not follow ----------------------------------------------------------------


def test_a_frozen_encoder_stops_the_arm_before_a_hard_limit() -> None:
    clock, robot, sim, drv, src, task = _setup(Q_NEAR)
    drv.freeze_at = 3
    res = _run(drv, src, robot, task, clock, _outward(clock))
    assert res.outcome == "not_following" and "frozen encoder" in res.reason, res.reason
    assert sim.fault is None and sim.q[0] < robot.limits().q_max[0]
    assert res.iterations <= 3 + Supervision().frozen_cycles + 1


def test_a_robot_ignoring_every_command_stops_within_the_window() -> None:
    act = ActuatorModel(encoder_noise_std=1e-4, seed=1)  # noisy readings: never identical
    clock, robot, _, drv, src, task = _setup(np.array([0.0, 0.0, 0.3, 0.0, 0.3, 0.0]), act)
    drv.ignore = True
    res = _run(drv, src, robot, task, clock, _outward(clock, joint=3))
    assert res.outcome == "not_following" and "does not follow" in res.reason, res.reason
    # The commanded motion reaches follow_min_motion within the first window: judged at its end.
    assert res.iterations * T <= Supervision().follow_window + 3 * T
    assert drv.stops == 1


def test_defaults_do_not_trip_on_a_lagging_delayed_quantized_robot() -> None:
    act = ActuatorModel(tau=0.1, delay_steps=2, qddot_max=5.0, encoder_resolution=1e-5, seed=0)
    clock, robot, sim, drv, src, task = _setup(Q_NEAR, act)
    # Full speed into the limit then the guard's braking: the hardest case for the check.
    res = _run(drv, src, robot, task, clock, _outward(clock, joint=0), max_iterations=200)
    assert res.outcome == "max_iterations", res.reason
    assert sim.fault is None


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("max_hold", 0.01),
        ("max_hold", float("nan")),
        ("max_overruns", 0),
        ("frozen_cycles", 1),
        ("follow_window", 0.0),
        ("follow_tolerance", -1.0),
        ("frozen_motion", float("inf")),
    ],
)
def test_bad_supervision_thresholds_are_refused(field: str, value: float) -> None:
    clock, robot, _, drv, src, task = _setup(Q_NEAR)
    sup = Supervision(**{field: value})
    with pytest.raises(ConfigurationError, match=f"supervision.{field}") as err:
        _run(drv, src, robot, task, clock, make_law("classical"), supervision=sup)
    assert err.value.argument == f"supervision.{field}"
