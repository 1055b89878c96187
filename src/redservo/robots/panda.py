"""The Franka Emika Panda (7 revolute joints) with an eye-in-hand wrist camera.

Kinematics: the modified (Craig) DH parameters published in the Franka Control
Interface documentation ("Robot and interface specifications", Denavit–Hartenberg
parameters), in metres and radians::

    joint   a         d       alpha
    1       0         0.333   0
    2       0         0       -π/2
    3       0         0.316   +π/2
    4       0.0825    0       +π/2
    5      -0.0825    0.384   -π/2
    6       0         0       +π/2
    7       0.088     0       +π/2
    flange  0         0.107   0

The end-effector frame is the flange (without the Franka Hand). Joint limits are
the published Panda limits (rad), ``q_min = (-2.8973, -1.7628, -2.8973, -3.0718,
-2.8973, -0.0175, -2.8973)`` and ``q_max = (2.8973, 1.7628, 2.8973, -0.0698,
2.8973, 3.7525, 2.8973)``; the FR3 successor has different ones. Velocity and
acceleration limits are the published ones of the same page (:data:`PANDA_QDOT_MAX`,
:data:`PANDA_QDDOT_MAX`).

Choice (the camera is not part of the product): ``eMc`` models a wrist camera
on a bracket at the flange, looking along the flange z axis (``cRe = I``),
its optical centre ``WRIST_CAMERA_OFFSET = (0.05, 0.0, 0.04)`` m from the flange
origin (5 cm off the axis, 4 cm beyond the flange face), roughly where
RealSense-type wrist mounts put it.
"""

from __future__ import annotations

import math
from typing import ClassVar, Final

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.robots.dh import DHLink, DHRobot
from redservo.spatial import make_transform

__all__ = ["PANDA_QDDOT_MAX", "PANDA_QDOT_MAX", "PANDA_Q_MAX", "PANDA_Q_MIN", "Panda"]

PANDA_Q_MIN: Final = (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973)
"""Published lower joint limits (rad)."""
PANDA_Q_MAX: Final = (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973)
"""Published upper joint limits (rad)."""
PANDA_QDOT_MAX: Final = (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)
"""Published maximum joint velocities (rad/s), Franka Control Interface "Limits for Panda"."""
PANDA_QDDOT_MAX: Final = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)
"""Published maximum joint accelerations (rad/s²), same source."""
WRIST_CAMERA_OFFSET: Final = (0.05, 0.0, 0.04)
"""Default optical-centre position in the flange frame (m)."""

_H2 = math.pi / 2
# (a, d, alpha) per joint, modified DH.
_MDH: Final = (
    (0.0, 0.333, 0.0),
    (0.0, 0.0, -_H2),
    (0.0, 0.316, _H2),
    (0.0825, 0.0, _H2),
    (-0.0825, 0.384, -_H2),
    (0.0, 0.0, _H2),
    (0.088, 0.0, _H2),
)
_FLANGE_D: Final = 0.107


class Panda(DHRobot):
    """Franka Emika Panda, modified DH, flange end-effector, wrist camera.

    Args:
        eMc: 4x4 camera pose in the flange frame (default: module docstring).
    """

    JOINT_NAMES: ClassVar[tuple[str, ...]] = tuple(f"panda_joint{i}" for i in range(1, 8))

    def __init__(self, *, eMc: ArrayLike | None = None) -> None:
        links = [
            DHLink(a=a, d=d, alpha=alpha, q_min=lo, q_max=hi, name=name)
            for (a, d, alpha), lo, hi, name in zip(
                _MDH, PANDA_Q_MIN, PANDA_Q_MAX, self.JOINT_NAMES, strict=True
            )
        ]
        super().__init__(
            links,
            convention="modified",
            flange=make_transform(t=(0.0, 0.0, _FLANGE_D)),
            eMc=make_transform(t=WRIST_CAMERA_OFFSET) if eMc is None else eMc,
            name="panda",
            qdot_max=PANDA_QDOT_MAX,
            qddot_max=PANDA_QDDOT_MAX,
        )

    @staticmethod
    def ready_configuration() -> FloatArray:
        """Return the usual "ready" posture ``(0, -π/4, 0, -3π/4, 0, π/2, π/4)`` (rad)."""
        return np.array([0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4])
