"""Run a control law on a robot: interfaces, a fixed-period servo loop, a simulated arm.

* :class:`RobotInterface` and :class:`FeatureSource`: what to implement for a real arm
  and camera (docs/real-robot.md);
* :class:`ServoLoop`: the loop (fixed period, watchdog, guard, clean stops), writing the
  simulator's log format;
* :class:`Supervision`: the late-loop and not-following thresholds of the loop;
* :class:`ClockFault`: a time stamp that broke the loop's clock contract (every stamp on
  the loop's monotonic clock: :mod:`redservo.hardware.clock`);
* :class:`ActuatorModel`, :class:`SimulatedRobot`, :class:`IdealFeatureSource`,
  :class:`VirtualClock`: a realistic simulated arm (lag, delay, saturation, encoder)
  behind the same interfaces, to rehearse a run (``examples/real_robot.py``).
"""

from __future__ import annotations

from redservo.control.guard import GuardReport, guard_command
from redservo.hardware.actuators import ACTUATOR_KEYS, ActuatorModel
from redservo.hardware.clock import ClockFault
from redservo.hardware.loop import ServoLoop
from redservo.hardware.protocols import FeatureMeasurement, FeatureSource, RobotInterface
from redservo.hardware.recorder import SERVO_OUTCOMES, ServoOutcome, ServoResult
from redservo.hardware.simulated import IdealFeatureSource, SimulatedRobot, VirtualClock
from redservo.hardware.supervision import Supervision

__all__ = [
    "ACTUATOR_KEYS",
    "SERVO_OUTCOMES",
    "ActuatorModel",
    "ClockFault",
    "FeatureMeasurement",
    "FeatureSource",
    "GuardReport",
    "IdealFeatureSource",
    "RobotInterface",
    "ServoLoop",
    "ServoOutcome",
    "ServoResult",
    "SimulatedRobot",
    "Supervision",
    "VirtualClock",
    "guard_command",
]
