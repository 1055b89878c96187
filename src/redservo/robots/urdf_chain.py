"""Compile the chain of a URDF file into the fixed transforms and axes of a :class:`ChainRobot`.

:func:`compile_chain` walks the joints from ``base_link`` down to ``camera_link`` (as
:func:`redservo.robots.urdf_parse.chain` lists them) once, at load:

* a ``fixed`` joint's ``<origin>`` is multiplied into the running fixed transform;
* a servoed joint (``revolute``, ``continuous`` — one angle — or ``prismatic``) closes it:
  the transform up to and including its ``<origin>`` becomes its ``F_i``, its ``<axis>``
  (already normalised by the parser) its axis;
* a locked joint (a movable joint left out of ``joints=``, a ``<mimic>`` joint included)
  is folded like a fixed one, with its motion at its locked value (``locked_q``): a mimic
  joint does not follow the joint it mimics, exactly as in the reduced Pinocchio model
  (Pinocchio reads ``<mimic>`` as an independent joint, which is then locked);
* ``floating`` and ``planar`` joints cannot be on the chain (``URDFRobot`` refuses them
  before; this module raises :class:`ConfigurationError` too).

The transform after the last servoed joint is ``F_end``, the pose of ``camera_link`` in
that joint's frame. URDF origins are ``Trans(xyz) · Rz(yaw) Ry(pitch) Rx(roll)`` with
``rpy = (roll, pitch, yaw)`` (rad) and ``xyz`` in m.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.robots.base import JointType
from redservo.robots.urdf_parse import URDFJoint
from redservo.robots.urdf_values import Triple

__all__ = ["CompiledChain", "compile_chain", "origin_transform"]

CompiledChain = tuple[list[FloatArray], FloatArray, list[JointType], FloatArray]
"""``(origins, axes, joint_types, end)``: the arguments of :class:`ChainRobot`."""


def origin_transform(xyz: Triple, rpy: Triple) -> FloatArray:
    """Return the 4x4 transform of a URDF ``<origin xyz rpy>``: ``Trans(xyz) Rz Ry Rx``."""
    cr, sr = math.cos(rpy[0]), math.sin(rpy[0])
    cp, sp = math.cos(rpy[1]), math.sin(rpy[1])
    cy, sy = math.cos(rpy[2]), math.sin(rpy[2])
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, xyz[0]],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr, xyz[1]],
            [-sp, cp * sr, cp * cr, xyz[2]],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def _motion(joint: URDFJoint, value: float) -> FloatArray:
    """The 4x4 motion of a one-variable joint at ``value`` (m or rad) about/along its axis."""
    k = np.asarray(joint.axis, dtype=float)
    T = np.eye(4)
    if joint.kind == "prismatic":
        T[:3, 3] = value * k
        return T
    c, s = math.cos(value), math.sin(value)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    T[:3, :3] = c * np.eye(3) + s * K + (1.0 - c) * np.outer(k, k)
    return T


def compile_chain(
    source: str,
    path: Sequence[URDFJoint],
    servo: Sequence[URDFJoint],
    locked: Mapping[str, float],
) -> CompiledChain:
    """Fold the joints of ``path`` into a chain of the ``servo`` joints (module docstring).

    Args:
        source: The file name, for error messages.
        path: Every joint from ``base_link`` to ``camera_link``, in order (fixed ones too).
        servo: The servoed joints, a subsequence of ``path`` in chain order.
        locked: Values (m or rad) of the locked one-variable joints, by name.

    Raises:
        ConfigurationError: a ``floating`` or ``planar`` joint on the path, or a locked joint
            without a value.
    """
    servo_names = {j.name for j in servo}
    origins: list[FloatArray] = []
    axes: list[Triple] = []
    types: list[JointType] = []
    T = np.eye(4)
    for joint in path:
        T = T @ origin_transform(joint.xyz, joint.rpy)
        if joint.name in servo_names:
            origins.append(T)
            axes.append(joint.axis)
            types.append("prismatic" if joint.kind == "prismatic" else "revolute")
            T = np.eye(4)
        elif joint.kind in ("revolute", "continuous", "prismatic"):
            if joint.name not in locked:
                raise ConfigurationError(  # pragma: no cover - locked_values covers every one
                    f"joint {joint.name!r} of {source} is locked but has no value",
                    argument="locked_q",
                )
            T = T @ _motion(joint, locked[joint.name])
        elif joint.kind != "fixed":
            raise ConfigurationError(
                f"joint {joint.name!r} of {source} is {joint.kind}; the chain to camera_link "
                "may hold revolute, continuous, prismatic and fixed joints",
                argument="path",
            )
    if len(origins) != len(servo):
        raise ConfigurationError(  # pragma: no cover - _servo_joints picks them from the path
            f"internal: {len(servo) - len(origins)} servoed joint(s) are not on the chain of "
            f"{source}"
        )
    return origins, np.array(axes, dtype=float), types, T
