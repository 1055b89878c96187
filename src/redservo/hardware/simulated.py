"""A simulated robot and camera behind the hardware interfaces, and a virtual clock.

* :class:`SimulatedRobot` implements :class:`~redservo.hardware.RobotInterface` with a
  kinematic model and an :class:`~redservo.hardware.ActuatorModel`: the joints move in
  fixed steps of ``period`` seconds of the clock, under the last command received.
* :class:`IdealFeatureSource` implements :class:`~redservo.hardware.FeatureSource` by
  measuring the task's features from the simulated robot's *true* camera pose (through any
  :class:`~redservo.sensors.Sensor`, exact by default).
* :class:`VirtualClock` is a clock whose ``sleep`` advances time instantly: with it a
  servo loop of minutes runs in a fraction of a second, deterministically.

Units: seconds, metres, radians.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.hardware.actuators import ActuatorModel
from redservo.hardware.clocked import ClockedArm
from redservo.hardware.protocols import FeatureMeasurement
from redservo.robots.base import Robot
from redservo.scene import Scene
from redservo.sensors import FrameNoise, IdealSensor, Sensor
from redservo.task import VisualTask

__all__ = ["IdealFeatureSource", "SimulatedRobot", "VirtualClock"]


class VirtualClock:
    """A monotonic clock that only moves when told: ``sleep(d)`` and ``advance(d)`` add ``d``.

    Pass the instance as the loop's ``clock`` (it is callable) and its :meth:`sleep` as the
    loop's ``sleep``.

    Args:
        start: Initial time (s).
    """

    def __init__(self, start: float = 0.0) -> None:
        self.now = float(start)

    def __call__(self) -> float:
        """Return the current time (s)."""
        return self.now

    def sleep(self, seconds: float) -> None:
        """Advance the time by ``seconds`` (negative values are ignored, as by ``time.sleep``)."""
        if seconds > 0.0:
            self.now += float(seconds)

    advance = sleep


class SimulatedRobot(ClockedArm):
    """A robot model with actuator dynamics, driven through the robot interface.

    The state advances in whole steps of ``period`` seconds of ``clock`` each time it is
    read or commanded, under the last command received (held between calls, as a
    velocity-controlled drive holds its set point). When a joint reaches a real limit it is
    held there and the robot *faults*: the next :meth:`send_velocity` raises
    :class:`~redservo.errors.JointLimitError`, as a real arm's protective stop would.

    Args:
        robot: The kinematic model (its limits are the hard limits).
        actuator: The actuator model (:meth:`ActuatorModel.ideal` for a perfect arm).
        q0: (n,) start configuration (m or rad), within the limits.
        clock: Monotonic time source (s), e.g. ``time.monotonic`` or a :class:`VirtualClock`.
        period: The simulation step (s), > 0; the actuator's delay counts in these steps,
            so use the servo loop's period.

    Raises:
        JointLimitError: ``q0`` is outside the robot's limits.
        ConfigurationError: ``period`` is not positive.
    """

    label = "simulated robot"

    def __init__(
        self,
        robot: Robot,
        actuator: ActuatorModel,
        q0: ArrayLike,
        clock: Callable[[], float] = time.monotonic,
        *,
        period: float,
    ) -> None:
        if not (math.isfinite(period) and period > 0.0):
            raise ConfigurationError(
                f"period must be a positive step (s), got {period!r}", argument="period"
            )
        self.actuator = actuator
        self._begin(robot, q0, clock, period)

    def _place(self, q: FloatArray) -> None:
        self.q = q.copy()
        self.actuator.reset(self.q)

    def _physics_step(self, cmd: FloatArray) -> FloatArray:
        q_next, _ = self.actuator.step(self.q, cmd, self.period)
        return q_next

    def _on_fault(self, q: FloatArray) -> None:
        self.actuator.reset(np.clip(q, self._limits.q_min, self._limits.q_max))

    def _settle(self, q: FloatArray) -> None:
        self.q = np.clip(q, self._limits.q_min, self._limits.q_max)

    def true_pose(self) -> FloatArray:
        """Return the true camera pose ``bMc`` (4x4) now."""
        self._advance()
        return self.robot.fkine(self.q, check_limits=False)

    # -- RobotInterface ------------------------------------------------------------------------

    def read_joints(self) -> tuple[float, FloatArray]:
        """Return ``(t, q_encoder)``: the state's time (s) and the encoder reading (n,)."""
        self._advance()
        return self._t, self.actuator.encoder(self.q)

    def _on_stop(self) -> None:
        """Drop the commands still in the actuator's delay line."""
        self.actuator.flush()


class IdealFeatureSource:
    """Features measured at a :class:`SimulatedRobot`'s true camera pose.

    Args:
        task: The visual task (its terms say what to measure).
        scene: The objects; scene time is the robot clock's time since the robot's start.
        robot: The simulated robot whose true pose the camera sees.
        sensor: How features are measured (default :class:`~redservo.sensors.IdealSensor`).
        noise_std: Standard deviation of additive noise on ``s`` (normalized units), >= 0.
        seed: Seed of that noise.
    """

    def __init__(
        self,
        task: VisualTask,
        scene: Scene,
        robot: SimulatedRobot,
        *,
        sensor: Sensor | None = None,
        noise_std: float = 0.0,
        seed: int | None = None,
    ) -> None:
        if not (math.isfinite(noise_std) and noise_std >= 0.0):
            raise ConfigurationError(
                f"noise_std must be >= 0 (normalized units), got {noise_std!r}",
                argument="noise_std",
            )
        self.task = task
        self.scene = scene
        self.robot = robot
        self.sensor: Sensor = sensor if sensor is not None else IdealSensor()
        self.sensor.reset()
        self.noise_std = float(noise_std)
        self._rng = np.random.default_rng(seed)
        self._noise = FrameNoise(self.noise_std, self._rng)

    def measure(self, t: float) -> FeatureMeasurement | None:
        """Measure at loop time ``t`` (s); None when the sensor lost the target."""
        bMc = self.robot.true_pose()
        reading = self.sensor.read(self.task, self.scene, bMc, t - self.robot.t_start)
        if reading.s is None:
            return None
        s = self._noise(reading)  # drawn once per frame: a held frame keeps its noise
        return FeatureMeasurement(s, tuple(reading.inv_depth), float(t), reading.no_pose)
