"""What every simulated arm behind :class:`~redservo.hardware.RobotInterface` shares: the
state advances in whole steps of ``period`` seconds of the loop's clock each time the arm is
read or commanded, under the last command received (held between calls, as a velocity-
controlled drive holds its set point); a joint beyond a real limit by more than the roundoff
of a step commanded onto it is a protective stop: the next command raises
:class:`~redservo.errors.JointLimitError`.

:class:`~redservo.hardware.SimulatedRobot` (a kinematic model and an actuator model) and
:class:`~redservo.physics.MujocoRobot` (MuJoCo's dynamics) say only how one period of
physics runs and what a fault or a stop does to their state.

Units: seconds, metres, radians.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_vector
from redservo.errors import JointLimitError
from redservo.robots.base import Robot

__all__ = ["ClockedArm"]

LIMIT_TOL = 1e-9
"""How far (m or rad) past a real limit a joint may be before it is a crossing: the roundoff
of a step commanded onto the limit (the simulator's ``LIMIT_TOLERANCE``)."""


class ClockedArm:
    """A simulated arm on the loop's clock (module docstring); a subclass implements
    :meth:`_place`, :meth:`_physics_step` and may refine :meth:`_on_fault`, :meth:`_settle`
    and :meth:`_on_stop`.

    Attributes:
        robot: The kinematic model (its limits are the hard limits).
        clock: The monotonic time source (s).
        period: The physics step (s).
        t_start: The clock's time (s) at the start.
        fault: The protective stop's message, None while the arm is fine.
        commands: How many commands were accepted.
        stops: How many times :meth:`stop` was called.
    """

    label = "simulated arm"
    """How the fault message names the arm."""

    def _begin(
        self, robot: Robot, q0: ArrayLike, clock: Callable[[], float], period: float
    ) -> None:
        """Check ``q0`` (n,) against the robot's limits, place the arm there
        (:meth:`_place`) and start the clock."""
        self.robot = robot
        self.clock = clock
        self.period = float(period)
        self._limits = robot.limits()
        self._place(self._limits.check(q0, "q0"))
        self.t_start = float(clock())
        self._t = self.t_start
        self._cmd = np.zeros(robot.n)
        self.fault: str | None = None
        self.commands = 0
        self.stops = 0

    def _place(self, q: FloatArray) -> None:
        """Put the arm at rest at ``q`` (n,), checked within the limits."""
        raise NotImplementedError

    def _physics_step(self, cmd: FloatArray) -> FloatArray:
        """Run one period under the command ``cmd`` (n,); return the joints' positions (n,)."""
        raise NotImplementedError

    def _on_fault(self, q: FloatArray) -> None:
        """What a new protective stop does at positions ``q`` (n,) past a limit."""

    def _settle(self, q: FloatArray) -> None:
        """Keep ``q`` (n,), the positions after a period, as the state."""

    def _on_stop(self) -> None:
        """What :meth:`stop` does besides commanding zero velocity."""

    @property
    def t(self) -> float:
        """Time (s, on ``clock``) of the simulated state."""
        return self._t

    def _advance(self) -> None:
        """Run the physics up to the clock's current time, in whole periods."""
        steps = math.floor((self.clock() - self._t) / self.period + 1e-6)
        lo, hi = self._limits.q_min, self._limits.q_max
        for _ in range(max(steps, 0)):
            cmd = self._cmd if self.fault is None else np.zeros_like(self._cmd)
            q = self._physics_step(cmd)
            self._t += self.period
            crossed = np.flatnonzero((q < lo - LIMIT_TOL) | (q > hi + LIMIT_TOL))
            if crossed.size and self.fault is None:
                i = int(crossed[0])
                self.fault = (
                    f"{self.label}: joint {i} ({self.robot.joint_names[i]}) reached its "
                    f"limit at t = {self._t - self.t_start:.3f} s; protective stop"
                )
                self._on_fault(q)
            self._settle(q)

    def send_velocity(self, qdot: FloatArray) -> None:
        """Hold the command ``qdot`` (n,) from now on.

        Raises:
            JointLimitError: the arm faulted on a joint limit (protective stop).
        """
        self._advance()
        if self.fault is not None:
            raise JointLimitError(self.fault)
        self._cmd = as_vector(qdot, "qdot", self.robot.n).copy()
        self.commands += 1

    def stop(self) -> None:
        """Command zero velocity (and what :meth:`_on_stop` adds)."""
        self._advance()
        self._cmd = np.zeros(self.robot.n)
        self._on_stop()
        self.stops += 1
