"""The ROS 2 robot interface over real DDS on the loopback (issue 31): a second process
publishes ``JointState`` and records the commands; fault tests (dead publisher, stamps from
another clock, wrong joint names, NaN). No mock of cyclonedds."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

from redservo import make_law
from redservo.features import PointFeature
from redservo.hardware import (
    ActuatorModel,
    FeatureMeasurement,
    ServoLoop,
    SimulatedRobot,
    Supervision,
    VirtualClock,
)
from redservo.robots import Afma6
from redservo.ros2.faults import MessageError
from redservo.ros2.robot import Ros2Robot, check_joint_names
from redservo.ros2.stamps import EpochStamps
from redservo.ros2.transport import Ros2Node
from redservo.task import TaskTerm, VisualTask

ROOT = Path(__file__).resolve().parents[1]
JOINTS = [f"joint{i}" for i in range(1, 7)]
DOMAIN = 100 + os.getpid() % 50  # per test process; 100-149: no other ros2 test file uses it
PREFIX = f"/robot_{os.getpid()}"  # topics of this process only: two runs may share a domain
TOPICS = {
    "joint_states": f"{PREFIX}/joint_states",
    "command": f"{PREFIX}/forward_velocity_controller/commands",
}


def peer(tmp_path: Path, *args: str) -> tuple[subprocess.Popen[bytes], Path]:
    """Start tests/ros2_peer.py on this test's domain; return the process and its output."""
    out = tmp_path / f"peer{len(list(tmp_path.iterdir()))}.json"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    cmd = [
        sys.executable,
        str(ROOT / "tests" / "ros2_peer.py"),
        str(DOMAIN),
        str(out),
        "--prefix",
        PREFIX,
        *args,
    ]
    return subprocess.Popen(cmd, env=env), out


def finish(proc: subprocess.Popen[bytes], out: Path) -> dict[str, Any]:
    assert proc.wait(timeout=60) == 0
    result: dict[str, Any] = json.loads(out.read_text())
    return result


@pytest.fixture(scope="module")
def node() -> Ros2Node:
    return Ros2Node(DOMAIN)


class Fixed:
    """A feature source with a fresh, constant measurement at each call."""

    def measure(self, t: float) -> FeatureMeasurement:
        return FeatureMeasurement(np.array([0.05, 0.02]), (np.array([1 / 0.6]),), t)


def _loop(robot: Any, **kw: Any) -> ServoLoop:
    model = Afma6()
    task = VisualTask([TaskTerm(PointFeature(), "target")], [0.0, 0.0])
    kw.setdefault("duration", 10.0)
    return ServoLoop(
        robot,
        Fixed(),
        model,
        task,
        make_law("classical"),
        model.limits(),
        period=0.04,
        lam=0.5,
        watchdog_timeout=0.2,
        stop_at_convergence=False,
        **kw,
    )


@pytest.fixture(scope="module", autouse=True)
def _warm_kernels() -> None:
    """Compile (or load) the law's kernels before any real-time loop runs."""
    clock, model = VirtualClock(), Afma6()
    sim = SimulatedRobot(model, ActuatorModel.ideal(), [0, 0, 0.3, 0, 0.3, 0], clock, period=0.04)
    _loop(sim, clock=clock, sleep=clock.sleep, max_iterations=3).run()


def test_joint_states_map_to_the_model_order_and_commands_reach_the_other_process(
    node: Ros2Node, tmp_path: Path
) -> None:
    proc, out = peer(tmp_path, "--duration", "3")
    with Ros2Robot(node, JOINTS, **TOPICS) as robot:
        t, q = robot.wait_for_joints(20.0)
        np.testing.assert_allclose(q, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6])  # names were scrambled
        assert abs(time.monotonic() - t) < 1.0  # epoch stamp on the monotonic clock
        assert robot.wait_for_subscriber(20.0) >= 1  # the peer's command reader matched
        robot.send_velocity(np.arange(6) * 0.01)
        robot.stop()
    got = finish(proc, out)["received"]
    assert got[-2:] == [[0.0, 0.01, 0.02, 0.03, 0.04, 0.05], [0.0] * 6]


def test_close_sends_zero_after_a_nonzero_command(node: Ros2Node, tmp_path: Path) -> None:
    proc, out = peer(tmp_path, "--duration", "2.5")
    robot = Ros2Robot(node, JOINTS, **TOPICS)
    robot.wait_for_joints(20.0)
    time.sleep(0.5)
    robot.send_velocity(np.full(6, 0.02))
    robot.close()
    robot.close()
    got = finish(proc, out)["received"]
    assert got == [[0.02] * 6, [0.0] * 6]


def test_a_dead_publisher_ends_the_loop_stale_and_stops_the_arm(
    node: Ros2Node, tmp_path: Path
) -> None:
    proc, out = peer(tmp_path, "--duration", "1.5")
    # The peer publishes fixed joint states and executes no command: the loop's following
    # check would end the run first (not_following, after its 1 s window); this test is about
    # the publisher dying, so that check is given a window longer than the run.
    patient = Supervision(follow_window=30.0, frozen_cycles=10_000)
    with Ros2Robot(node, JOINTS, **TOPICS) as robot:
        robot.wait_for_joints(20.0)
        result = _loop(robot, supervision=patient).run()
    finish(proc, out)
    assert result.outcome == "stale_measurement"
    assert "no fresh joint readings" in result.summary["reason"]
    assert robot.stops == 1


def test_stamps_on_another_clock_never_count_as_fresh(node: Ros2Node, tmp_path: Path) -> None:
    proc, _out = peer(tmp_path, "--duration", "2", "--stamps", "monotonic")
    with Ros2Robot(node, JOINTS, **TOPICS) as robot:
        robot.wait_for_joints(20.0)
        result = _loop(robot).run()
    proc.kill()
    assert result.outcome == "stale_measurement"
    assert "is it on the loop's monotonic clock?" in result.summary["reason"]


def test_stamps_from_the_future_are_a_clock_fault(node: Ros2Node, tmp_path: Path) -> None:
    proc, _out = peer(tmp_path, "--duration", "2", "--stamps", "future")
    with Ros2Robot(node, JOINTS, **TOPICS) as robot:
        robot.wait_for_joints(20.0)
        result = _loop(robot).run()
    proc.kill()
    assert result.outcome == "clock_fault"
    assert result.clock_fault is not None and result.clock_fault.kind == "future"


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--names", ",".join(JOINTS[:5])], r"/joint_states lacks the joints \['joint6'\]"),
        (["--nan-after", "0"], r"non-finite position for \['joint1'\]"),
    ],
)
def test_a_joint_state_without_a_joint_or_with_nan_stops_the_arm(
    node: Ros2Node, tmp_path: Path, args: list[str], match: str
) -> None:
    proc, _out = peer(tmp_path, "--duration", "2", *args)
    with Ros2Robot(node, JOINTS, **TOPICS) as robot:
        with pytest.raises(MessageError, match=match) as err:
            robot.wait_for_joints(20.0)
    proc.kill()
    assert err.value.argument == TOPICS["joint_states"]


def test_no_publisher_is_one_error_naming_the_topic(node: Ros2Node) -> None:
    with Ros2Robot(node, JOINTS, **{**TOPICS, "joint_states": "/nobody/joint_states"}) as robot:
        with pytest.raises(MessageError, match="no JointState on /nobody/joint_states within"):
            robot.wait_for_joints(0.3)


def test_nobody_on_the_command_topic_is_one_error_naming_it(node: Ros2Node) -> None:
    topic = f"/unread_{os.getpid()}/commands"  # read by no process, whoever shares the domain
    with Ros2Robot(node, JOINTS, **{**TOPICS, "command": topic}) as robot:
        with pytest.raises(MessageError, match=f"nobody subscribes to {topic} within 0.3 s") as e:
            robot.wait_for_subscriber(0.3)
        assert robot.commands == 0 and robot.subscribers() == 0
    assert e.value.argument == topic
    assert "controller loaded" in str(e.value) and "nothing was sent" in str(e.value)


def test_bad_joint_lists_are_one_error_naming_the_key() -> None:
    for bad, match in [
        ([], "non-empty list"),
        (["a", "a"], r"\['a'\] more than once"),
        (["a", ""], "non-empty string"),
    ]:
        with pytest.raises(ValueError, match=match):
            check_joint_names(bad, "robot.joints")


def test_epoch_offset_is_estimated_from_the_closest_pair() -> None:
    # two samples (monotonic, wall, monotonic): read in 2 s, then in 0.2 ms
    walls = iter([1000.0, 1010.0])
    monos = iter([0.0, 2.0, 10.0, 10.0002])
    st = EpochStamps(wall=lambda: next(walls), monotonic=lambda: next(monos), samples=2)
    assert st.offset == pytest.approx(1010.0 - 10.0001)
    assert st.uncertainty == pytest.approx(0.0001)
    assert st.to_loop(st.to_ros(12.5)) == pytest.approx(12.5, abs=1e-6)
