"""The rehearsal arm: a scenario's MuJoCo arm served on a ROS 2 arm's topics, in real time.

``redservo sim-arm SCENARIO`` runs :class:`RehearsalArm` in its own process: the arm's
dynamics (:class:`~redservo.physics.MujocoArm`, velocity servos at a 1 ms physics step)
advance with the wall clock; it publishes ``JointState`` (epoch stamps, as
``joint_state_broadcaster``) at ``rate`` Hz and, with a camera, the rendered ``Image`` and
its ``CameraInfo``; it executes the ``Float64MultiArray`` velocity commands it receives, as
a ros2_control ``JointGroupVelocityController``, and commands zero by itself when no
command arrived for ``command_timeout`` seconds (a controller's command timeout): killing
the servo process stops it. A command of the wrong length or with NaN is refused (counted,
said once on stderr) as ros2_control refuses it. A joint that reaches its limit is a
protective stop: the arm holds zero until restarted.

Units: seconds, radians, rad/s; rates in Hz.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from redservo.errors import ConfigurationError
from redservo.experiment.build import Experiment
from redservo.ros2.messages import Float64MultiArray, Header, JointState
from redservo.ros2.naming import validate_topic
from redservo.ros2.stamps import EpochStamps
from redservo.ros2.transport import COMMANDS, Ros2Node

__all__ = ["ArmStats", "RehearsalArm"]

_MAX_CATCH_UP = 0.05  # s of physics per cycle at most; beyond, real time is dropped (counted)


@dataclass
class ArmStats:
    """What the rehearsal arm saw (``redservo sim-arm --out FILE``)."""

    commands: int = 0
    refused: int = 0
    command_ages: list[float] = field(default_factory=list)
    """Publish (the writer's source time stamp) to arrival, per command (s)."""
    timeouts: int = 0
    """Times the arm stopped by itself: no command for ``command_timeout``."""
    stopped_at: list[float] = field(default_factory=list)
    """Seconds from the last command's arrival to the self-stop, per timeout."""
    dropped_time: float = 0.0
    """Physics time skipped because a cycle came late (s)."""
    published: int = 0
    fault: str | None = None
    last_command: list[float] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        ages = np.asarray(self.command_ages)
        return {
            "commands": self.commands,
            "refused": self.refused,
            "command_age_p50": float(np.percentile(ages, 50)) if ages.size else None,
            "command_age_p99": float(np.percentile(ages, 99)) if ages.size else None,
            "command_age_max": float(ages.max()) if ages.size else None,
            "timeouts": self.timeouts,
            "stopped_after": self.stopped_at,
            "dropped_time": self.dropped_time,
            "published": self.published,
            "fault": self.fault,
            "last_command": self.last_command,
        }


class RehearsalArm:
    """A scenario's arm as a ROS 2 arm (module docstring).

    Args:
        exp: The built scenario (robot, scene, start ``q0``, camera).
        node: The DDS participant.
        joints: ROS joint names in the model's order (default: the model's joint names).
        joint_states: Topic the joint states are published on.
        command: Topic of the velocity commands.
        rate: Joint-state rate (Hz), also the physics update rate, in [10, 1000].
        command_timeout: Command zero when no command arrived for this long (s), > 0.
        camera: A :class:`~redservo.ros2.sim_camera.SimCamera` to publish the arm's rendered
            view (None: no camera).

    Raises:
        ConfigurationError: a rate, timeout, topic or joint list is out of range.
    """

    def __init__(
        self,
        exp: Experiment,
        node: Ros2Node,
        *,
        joints: Sequence[str] | None = None,
        joint_states: str = "/joint_states",
        command: str = "/forward_velocity_controller/commands",
        rate: float = 250.0,
        command_timeout: float = 0.1,
        camera: Any = None,
    ) -> None:
        from redservo.physics.arm import MujocoArm

        if not (math.isfinite(rate) and 10.0 <= rate <= 1000.0):
            raise ConfigurationError(f"rate must be 10-1000 Hz, got {rate!r}", argument="rate")
        if not (math.isfinite(command_timeout) and command_timeout > 0.0):
            raise ConfigurationError(
                f"command_timeout must be a positive number of seconds, got {command_timeout!r}",
                argument="command_timeout",
            )
        self.joints = list(joints or exp.robot.joint_names)
        if len(self.joints) != exp.robot.n:
            raise ConfigurationError(
                f"joints names {len(self.joints)} joints; the {exp.robot.name} has {exp.robot.n}",
                argument="joints",
            )
        self.exp, self.node = exp, node
        self.arm = MujocoArm(exp.robot, exp.scene, camera=exp.camera, q_ref=exp.q0)
        self.arm.set_q(exp.q0)
        self.limits = exp.robot.limits()
        self.rate, self.command_timeout = float(rate), float(command_timeout)
        self.stamps = EpochStamps()
        self._js = node.writer(validate_topic(joint_states, "joint_states"), JointState)
        self._cmd = node.reader(validate_topic(command, "command"), Float64MultiArray, COMMANDS)
        self.camera = camera
        self.stats = ArmStats()
        self.stop_event = threading.Event()
        self._qdot = np.zeros(exp.robot.n)
        self._last_cmd: float | None = None  # monotonic arrival of the last command
        self._told: set[str] = set()

    def _say_once(self, what: str, text: str) -> None:
        if what not in self._told:
            self._told.add(what)
            print(f"sim-arm: {text}", file=sys.stderr, flush=True)

    def _take_commands(self, now: float) -> None:
        wall = time.time()
        for msg in self._cmd.take(N=256):
            if not isinstance(msg, Float64MultiArray):
                continue
            v = np.asarray(msg.data, dtype=float)
            if v.shape != self._qdot.shape or not np.all(np.isfinite(v)):
                self.stats.refused += 1
                self._say_once(
                    "refused",
                    f"refused a command of {v.size} values (want {self._qdot.size} finite ones)",
                )
                continue
            self.stats.command_ages.append(wall - msg.sample_info.source_timestamp * 1e-9)  # type: ignore[attr-defined]
            self.stats.commands += 1
            self._qdot, self._last_cmd = v, now
        if self._last_cmd is not None and now - self._last_cmd > self.command_timeout:
            self.stats.timeouts += 1
            self.stats.stopped_at.append(now - self._last_cmd)
            self._say_once("timeout", "no command for the command timeout: stopping")
            self._qdot, self._last_cmd = np.zeros_like(self._qdot), None

    def _step(self, seconds: float) -> None:
        cmd = self._qdot if self.stats.fault is None else np.zeros_like(self._qdot)
        self.arm.step(cmd, seconds)
        q = self.arm.q
        out = np.flatnonzero((q < self.limits.q_min) | (q > self.limits.q_max))
        if out.size and self.stats.fault is None:
            self.stats.fault = f"joint {self.joints[int(out[0])]} reached its limit"
            self._say_once("fault", f"{self.stats.fault}: protective stop")

    def _publish(self, t_mono: float) -> None:
        header = Header(self.stamps.to_ros(t_mono), "base")
        q, qd = self.arm.q, self.arm.qdot
        self._js.write(
            JointState(header, self.joints, [float(x) for x in q], [float(x) for x in qd], [])
        )
        self.stats.published += 1

    def run(self, duration: float | None = None) -> ArmStats:
        """Serve until :attr:`stop_event` is set or ``duration`` (s) elapsed."""
        if self.camera is not None:
            self.camera.start()
        try:
            return self._serve(duration)
        finally:
            if self.camera is not None:
                self.camera.stop()

    def _serve(self, duration: float | None) -> ArmStats:
        period, step = 1.0 / self.rate, self.arm.timestep
        t_sim = start = time.monotonic()
        next_tick = start
        while not self.stop_event.is_set():
            now = time.monotonic()
            if duration is not None and now - start >= duration:
                break
            self._take_commands(now)
            lag = now - t_sim
            if lag > _MAX_CATCH_UP:
                self.stats.dropped_time += lag - _MAX_CATCH_UP
                t_sim = now - _MAX_CATCH_UP
            steps = math.floor((now - t_sim) / step + 1e-9)
            if steps > 0:
                self._step(steps * step)
                t_sim += steps * step
            self._publish(t_sim)
            if self.camera is not None:
                self.camera.update(self.arm.q, t_sim, t_sim - start)
            next_tick = max(next_tick + period, time.monotonic())
            self.stop_event.wait(max(next_tick - time.monotonic(), 0.0))
        self.stats.last_command = [float(x) for x in self._qdot]
        return self.stats
