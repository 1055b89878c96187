"""The MuJoCo arm behind the simulator's actuator hook and behind the robot interface.

* :class:`MujocoActuator` is an :class:`~redservo.simulation.loop.Actuator`: ``simulate(...,
  actuator=MujocoActuator(arm))`` sends each period's command to the MuJoCo arm, which
  follows it with its dynamics for ``dt`` seconds (``dt / timestep`` physics steps); the next
  ``q`` is MuJoCo's. The encoder is exact (MuJoCo's joint positions).
* :class:`MujocoRobot` is a :class:`~redservo.hardware.RobotInterface` for
  :class:`~redservo.hardware.ServoLoop`: like :class:`~redservo.hardware.SimulatedRobot`,
  the physics advances in whole ``period`` steps of the loop's clock each time the arm is
  read or commanded, and every reading is stamped on that clock. A joint beyond a real limit
  (by more than 1e-9) is a protective stop: the next command raises
  :class:`~redservo.errors.JointLimitError`.

Units: seconds, metres, radians.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_vector
from redservo.errors import ConfigurationError
from redservo.hardware.clocked import ClockedArm
from redservo.physics.arm import MujocoArm

__all__ = ["MujocoActuator", "MujocoRobot"]


class MujocoActuator:
    """The MuJoCo arm as the simulator's actuator model (module docstring).

    Args:
        arm: The arm; :meth:`reset` puts it at rest at the run's ``q0``.
    """

    def __init__(self, arm: MujocoArm) -> None:
        self.arm = arm

    def reset(self, q0: ArrayLike) -> None:
        """Start at rest at ``q0`` (n,) with fresh tracking statistics."""
        self.arm.set_q(q0)

    def step(self, q: ArrayLike, qdot_cmd: ArrayLike, dt: float) -> tuple[FloatArray, FloatArray]:
        """Follow ``qdot_cmd`` (n,) for ``dt`` s; return MuJoCo's ``(q, q̇)`` at the end.

        ``q`` (the simulator's copy of the state) is not used: the state is MuJoCo's."""
        self.arm.step(qdot_cmd, dt)
        return self.arm.q, self.arm.qdot

    def encoder(self, q: ArrayLike) -> FloatArray:
        """The exact joint positions ``q`` (n,)."""
        return as_vector(q, "q")


class MujocoRobot(ClockedArm):
    """A MuJoCo arm driven through the robot interface, on the loop's clock (module docstring).

    Args:
        arm: The arm.
        q0: (n,) start configuration (m or rad), within the robot's limits.
        clock: Monotonic time source (s): ``time.monotonic`` or a
            :class:`~redservo.hardware.VirtualClock`.
        period: Time (s) the physics advances per whole step of the clock, > 0 and a multiple
            of the arm's ``timestep`` (use the servo loop's period).

    Raises:
        JointLimitError: ``q0`` is outside the limits.
        ConfigurationError: ``period`` is not a positive multiple of the physics step.
    """

    label = "MuJoCo robot"

    def __init__(
        self,
        arm: MujocoArm,
        q0: ArrayLike,
        clock: Callable[[], float] = time.monotonic,
        *,
        period: float,
    ) -> None:
        ratio = period / arm.timestep if math.isfinite(period) and period > 0 else 0.0
        if ratio < 1.0 or abs(ratio - round(ratio)) > 1e-6:
            raise ConfigurationError(
                f"period must be a positive multiple of the physics step {arm.timestep} s, "
                f"got {period!r}",
                argument="period",
            )
        self.arm = arm
        self._begin(arm.robot, q0, clock, period)

    def _place(self, q: FloatArray) -> None:
        self.arm.set_q(q)

    def _physics_step(self, cmd: FloatArray) -> FloatArray:
        self.arm.step(cmd, self.period)
        return self.arm.q

    def true_pose(self) -> FloatArray:
        """The camera pose ``bMc`` (4x4) now, from MuJoCo's state."""
        self._advance()
        return self.arm.camera_pose()

    def read_joints(self) -> tuple[float, FloatArray]:
        """``(t, q)``: the state's time on the loop's clock (s) and the joint positions (n,)."""
        self._advance()
        return self._t, self.arm.q
