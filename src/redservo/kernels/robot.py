"""The kinematics of any robot pack: one kernel for every compiled robot kind.

The pack is the one of :mod:`redservo.robots.pack` (``(kind, eMc, cVe, coupling, offset,
par, base, flange, standard, frames, joints)``; kind 0 the Afma6, 1 a DH chain, 2 a chain of
fixed transforms and joint axes, e.g. a URDF robot). :func:`robot_kinematics` is what every
driver of the step kernel calls (the Controller's step of :mod:`redservo.kernels.control`,
the campaign loop); the robot objects call the kind's kernel directly, with the same
arguments, so the numbers are the same to the bit.
"""

from __future__ import annotations

from typing import Any

from redservo.kernels._jit import kernel
from redservo.kernels.chain import chain_kinematics
from redservo.kernels.kinematics import afma6_kinematics, dh_kinematics

__all__ = ["robot_kinematics"]


@kernel
def robot_kinematics(q: Any, robot: Any) -> Any:
    """``(bMc, J)``: the camera pose (4, 4; m) and ``J = cVe eJe`` (6, n) at ``q`` (n,)
    (rad or m) of the robot ``robot`` (module docstring)."""
    kind, eMc, cVe, coupling, offset, par, base, flange, standard, frames, joints = robot
    if kind == 0:
        return afma6_kinematics(q, eMc, cVe, coupling, offset)
    if kind == 1:
        return dh_kinematics(q, par, base, flange, standard, eMc, cVe)
    return chain_kinematics(q, frames, joints, eMc, cVe)
