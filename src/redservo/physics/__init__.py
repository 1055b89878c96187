"""A MuJoCo physics backend: the servo loop on a simulated arm, seen through a rendered camera.

* :class:`MujocoArm`: any redservo robot (and scene) as a MuJoCo model, its kinematics
  exact by construction (:mod:`redservo.physics.mjcf`), joints driven by velocity servos
  on a gravity-compensated arm at a fixed 1 ms step (:mod:`redservo.physics.arm`);
* :class:`MujocoActuator`: that arm as the simulator's actuator (``simulate(...,
  actuator=...)``): the law's command is tracked with the arm's dynamics;
* :class:`MujocoRobot`: the same arm behind :class:`~redservo.hardware.RobotInterface`,
  for :class:`~redservo.hardware.ServoLoop`;
* :class:`MujocoCamera`: a sensor that renders the arm's camera (light, shadows, noise,
  blur) and detects the features in the image with the image sensor's detectors.

Extra ``redservo[mujoco]``; offscreen rendering uses ``MUJOCO_GL=egl`` (docs/physics.md).
Importing this package does not import MuJoCo.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from redservo.physics.arm import MujocoArm, TrackingStats
    from redservo.physics.camera import MujocoCamera
    from redservo.physics.robot import MujocoActuator, MujocoRobot

__all__ = ["MujocoActuator", "MujocoArm", "MujocoCamera", "MujocoRobot", "TrackingStats"]

_WHERE = {
    "MujocoArm": "arm",
    "TrackingStats": "arm",
    "MujocoCamera": "camera",
    "MujocoActuator": "robot",
    "MujocoRobot": "robot",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        import importlib

        return getattr(importlib.import_module(f"redservo.physics.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'redservo.physics' has no attribute {name!r}")
