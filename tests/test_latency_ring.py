"""The latency compensation on the compiled kernels (issue 28, item 6): the command history's
ring of arrays and its compiled sum (``kernels/latency.motion``), and the points brought to
the present in one compiled call (``kernels/latency.present_points``), bit for bit the
Python code they replace (kept here as the reference) on fuzzed histories and measurements.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from redservo import Controller, JointLimits, make_law
from redservo.control import Measurement
from redservo.control.latency import CommandHistory, present
from redservo.features import PointFeature
from redservo.robots import Panda
from redservo.task import TaskTerm, VisualTask

_EPS = 1e-9


class _Reference:
    """The history as it was (a deque of commands, the sum in a Python loop)."""

    def __init__(self, period: float, jacobian: Callable[[Any], Any], horizon: float) -> None:
        self.period, self.jacobian, self.horizon = period, jacobian, horizon
        self.cmds: deque[list[Any]] = deque()
        self.ordered = True

    def record(self, t: float, q: Any, qdot: Any) -> None:
        if self.cmds and t < self.cmds[-1][0]:
            self.ordered = False
        self.cmds.append([float(t), q.copy(), qdot.copy(), None])
        while self.cmds[0][0] < t - self.horizon:
            self.cmds.popleft()

    def _first_after(self, stamp: float) -> int:
        cmds = self.cmds
        if not self.ordered:
            return 0
        first = len(cmds)
        while first > 0:
            end = cmds[first][0] if first < len(cmds) else cmds[-1][0] + self.period
            if end <= stamp + _EPS:
                break
            first -= 1
        return first

    def motion(self, stamp: float, now: float) -> Any:
        total = np.zeros(6)
        cmds = self.cmds
        for i in range(self._first_after(stamp), len(cmds)):
            cmd = cmds[i]
            end = cmds[i + 1][0] if i + 1 < len(cmds) else cmd[0] + self.period
            overlap = min(end, now) - max(cmd[0], stamp)
            if overlap <= _EPS:
                continue
            if cmd[3] is None:
                cmd[3] = self.jacobian(cmd[1]) @ cmd[2]
            total += cmd[3] * overlap
        return total


@pytest.mark.parametrize("seed", range(12))
def test_the_ring_of_arrays_sums_the_commands_as_the_python_loop_did(seed: int) -> None:
    """Fuzzed histories (jittered and repeated times, out of order in some, more commands
    than the ring's first slots, a horizon that drops the oldest) and stamps: the same
    displacement bit for bit at every step, the twists computed once each."""
    rng = np.random.default_rng(seed)
    n, period = int(rng.integers(2, 8)), float(rng.uniform(0.002, 0.05))
    M = rng.normal(size=(6, n))
    calls = {"got": 0, "want": 0}

    def jacobian(who: str) -> Callable[[Any], Any]:
        def jac(q: Any) -> Any:
            calls[who] += 1
            return M * np.cos(q)[None, :]

        return jac

    horizon = float(rng.choice([0.05, 1.0, 100.0]))
    got = CommandHistory(period, jacobian("got"), horizon)
    want = _Reference(period, jacobian("want"), horizon)
    t = 0.0
    for k in range(300):
        t += period * float(rng.choice([1.0, rng.uniform(0.5, 1.5), 0.0]))
        if seed % 4 == 3 and k % 37 == 5:
            t -= 2.5 * period  # out of time order: every command is looked at from then on
        q, qdot = rng.normal(size=n), rng.normal(size=n) * 10.0 ** rng.uniform(-3, 1)
        got.record(t, q, qdot)
        want.record(t, q, qdot)
        stamp = t - float(rng.uniform(0.0, 5.0)) * period
        now = t + float(rng.choice([0.0, period, rng.uniform(0, 2 * period)]))
        a, b = got.motion(stamp, now), want.motion(stamp, now)
        assert a.tobytes() == b.tobytes(), (k, a, b)
    assert calls["got"] == calls["want"] > 0  # each twist computed once, when first needed
    got.reset()
    assert not got.motion(0.0, t + 1.0).any()


def _task(depth: str) -> VisualTask:
    pts = np.array([[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [0.0, 0.0, 0.0]])
    star = np.array([-0.1, -0.1, 0.1, -0.1, 0.1, 0.1, 0.0, 0.02])
    terms = [TaskTerm(PointFeature(p), "sq") for p in pts]
    inv = None if depth == "current" else tuple(np.array([2.0]) for _ in pts)
    return VisualTask(terms, star, depth=depth, inv_depth_star=inv)


@pytest.mark.parametrize("depth", ["current", "desired", "mean"])
@pytest.mark.parametrize("scale", [1.0, 0.8])
def test_points_brought_to_the_present_in_one_compiled_call_equal_the_python_path(
    depth: str, scale: float
) -> None:
    """``present`` with the compiled engine of a task of points (``L`` and ``s + L·Δ`` in
    one kernel) gives the features of the Python path (the task's ``L``, numpy's product)
    bit for bit, on fuzzed features, depths and command histories."""
    robot = Panda()
    lim = robot.limits()
    limits = JointLimits(lim.q_min, lim.q_max, rho=0.1, qdot_max=0.5, qddot_max=4.0)
    task = _task(depth)
    ctl = Controller(robot, task, make_law("wln"), limits, lam=0.5, dt=0.04, depth_scale=scale)
    assert ctl.engine == "compiled"
    rng = np.random.default_rng(7)
    for k in range(60):
        q = lim.center + rng.uniform(-0.8, 0.8, robot.n) * lim.range / 2
        ctl.history.record(0.04 * k, q, rng.normal(size=robot.n) * 0.3)
        s = rng.normal(size=8) * 0.3
        meas = Measurement(s, tuple(np.array([rng.uniform(0.5, 5.0)]) for _ in range(4)), 0.04 * k)
        t = 0.04 * k + float(rng.uniform(0.01, 0.12))
        fast = present(task, ctl.history, meas, t, s, scale, ctl._compiled)
        slow = present(task, ctl.history, meas, t, s, scale)
        assert fast.s.tobytes() == slow.s.tobytes()
        assert fast.stamp == slow.stamp == t
        assert all(a.tobytes() == b.tobytes() for a, b in zip(fast.inv_depth, slow.inv_depth))


@pytest.mark.parametrize("kind", ["afma6", "panda", "urdf"])
def test_the_twists_from_the_compiled_kinematics_are_the_robot_objects(kind: str) -> None:
    """``kernels/latency.robot_twist`` (the robot's compiled kinematics, the product by BLAS)
    gives the history's twist ``robot.jacobian(q) @ q̇`` bit for bit, on fuzzed joints
    (beyond the limits too: the history does not check them) and commands over decades; a
    compensated Controller step on the compiled engine therefore equals the object path's
    (tests/test_controller_engine.py runs both with a camera's latency)."""
    from redservo.kernels import latency as kl
    from redservo.robots import Afma6

    if kind == "urdf":
        from redservo.robots.urdf import URDFRobot, shipped_urdf

        robot: Any = URDFRobot(shipped_urdf("panda"), camera_link="camera_link")
    else:
        robot = Afma6() if kind == "afma6" else Panda()
    pack = robot.kernel_pack()
    assert pack is not None
    lim = robot.limits()
    rng = np.random.default_rng(11)
    for _ in range(300):
        q = lim.center + rng.uniform(-1.2, 1.2, robot.n) * lim.range / 2
        qdot = rng.normal(size=robot.n) * 10.0 ** rng.uniform(-4, 1)
        want = robot.jacobian(q, check_limits=False) @ qdot
        assert kl.robot_twist(q, qdot, pack).tobytes() == want.tobytes()


@pytest.mark.parametrize("seed", range(6))
def test_the_sum_with_the_compiled_twists_in_one_call_is_the_python_loops(seed: int) -> None:
    """``CommandHistory.motion`` with the robot's kinematics pack (the missing twists and the
    sum in one compiled call, ``kernels/latency.robot_motion``, from the ring's joints and
    commands) gives the reference's displacement bit for bit (the robot object's Jacobian,
    the Python loop), on fuzzed histories: jittered, repeated and out-of-order times, more
    commands than the ring's first slots (it grows), commands kept as a buffer's part."""
    robot = Panda()
    pack = robot.kernel_pack()
    lim = robot.limits()
    rng = np.random.default_rng(100 + seed)
    period = float(rng.uniform(0.002, 0.05))
    horizon = float(rng.choice([0.05, 1.0, 100.0]))
    got = CommandHistory(period, lambda q: robot.jacobian(q, check_limits=False), horizon)
    want = _Reference(period, lambda q: robot.jacobian(q, check_limits=False), horizon)
    t = 0.0
    for k in range(200):
        t += period * float(rng.choice([1.0, rng.uniform(0.5, 1.5), 0.0]))
        if seed % 3 == 2 and k % 37 == 5:
            t -= 2.5 * period
        q = lim.center + rng.uniform(-1.0, 1.0, robot.n) * lim.range / 2
        qdot = rng.normal(size=robot.n) * 10.0 ** rng.uniform(-3, 0)
        buf = np.concatenate([rng.normal(size=3), qdot])  # as the compiled step keeps it
        got.keep(t, q.copy(), buf, slice(3, 3 + robot.n))
        want.record(t, q, qdot)
        stamp = t - float(rng.uniform(0.0, 5.0)) * period
        now = t + float(rng.choice([0.0, period, rng.uniform(0, 2 * period)]))
        a, b = got.motion(stamp, now, pack), want.motion(stamp, now)
        assert a.tobytes() == b.tobytes(), (k, a, b)
