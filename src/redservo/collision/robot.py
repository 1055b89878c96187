"""The collision geometry of the built-in robots: one capsule per link.

Each built-in model draws itself in the viewer as the segments between the origins of its
consecutive link frames (``robot.link_poses(q)``, base to tip). The collision model is
the same skeleton fattened: one capsule per segment of non-zero length, named after the
frame at its tip, with the radius of :data:`LINK_RADII` (where two frame origins coincide
the joint's axis passes through that point, so the two frames' origins are one point).

Where the radii come from (metres): they are *estimates*, chosen to enclose each link
rather than measured from CAD, rounded up (a margin is safer than a miss):

* ``panda``: 0.06 m for links 1–5 (the Panda's upper arm and forearm are about 0.12 m
  across on Franka's published dimension drawings), 0.05 m for link 6, 0.04 m for link 7
  and the flange.
* ``humanoid9``: CM01's virtual torso (:mod:`redservo.robots.humanoid`): torso 0.15 m
  (half an adult chest depth of about 0.3 m), head 0.10 m.
* ``afma6``: 0.08 m around the wrist and camera; the gantry's carriages, above the
  workspace, are not modelled.

Change or extend with :func:`link_capsules` ``radii=`` (a mapping from frame name to
radius). A URDF robot uses its own ``<collision>`` elements
(:mod:`redservo.collision.urdf_query`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.robots.base import Robot

__all__ = ["LINK_RADII", "LinkCapsule", "link_capsules", "point_jacobians"]

_PANDA = {"panda_joint1": 0.06, "panda_joint2": 0.06, "panda_joint3": 0.06}
_PANDA |= {"panda_joint4": 0.06, "panda_joint5": 0.06, "panda_joint6": 0.05}
_PANDA |= {"panda_joint7": 0.04, "ee": 0.04}
_HUMANOID = {"pelvis_pitch": 0.15, "spine_pitch": 0.15, "neck_yaw": 0.10, "ee": 0.10}

LINK_RADII: Final[dict[str, dict[str, float]]] = {
    "panda": _PANDA,
    "humanoid9": _HUMANOID,
    "afma6": {"x": 0.08, "y": 0.08, "z": 0.08, "A": 0.08, "B": 0.08, "ee": 0.08},
}
"""Capsule radius (m) per robot name and link-frame name (module docstring)."""

_DEFAULT_RADIUS: Final = 0.05


@dataclass(frozen=True)
class LinkCapsule:
    """A capsule between the origins of link frames ``a`` and ``b`` (indices into
    ``list(robot.link_poses(q))``), of ``radius`` and axis ``length`` (m); ``name`` is
    frame ``b``'s. Consecutive capsules share a frame (``b`` of one is ``a`` of the next)."""

    name: str
    a: int
    b: int
    radius: float
    length: float


def link_capsules(
    robot: Robot, radii: Mapping[str, float] | None = None
) -> tuple[LinkCapsule, ...]:
    """The capsules of a built-in robot (module docstring), base to tip.

    Args:
        robot: Afma6, Humanoid9, Panda or any DHRobot.
        radii: Radius (m) per frame name, overriding :data:`LINK_RADII` (default 0.05 m).

    Raises:
        ConfigurationError: another kind of robot, or a radius is not > 0.
    """
    own = getattr(robot, "collision_capsules", None)  # a robot with its own geometry (MJCF)
    if own is not None:
        return tuple(own(radii))
    poses = _poses(robot, (robot.q_min + robot.q_max) / 2)
    table = dict(LINK_RADII.get(robot.name.lower(), {}))
    table |= dict(radii or {})
    for key, r in table.items():
        if not (np.isfinite(r) and r > 0.0):
            raise ConfigurationError(f"radius of link {key!r} must be > 0 (m), got {r}")
    names = list(poses)
    p = np.stack([poses[name][:3, 3] for name in names])
    out = []
    a = 0
    for b in range(1, len(names)):
        length = float(np.linalg.norm(p[b] - p[a]))
        if length < 1e-9:  # the same point: the joint's axis passes through it
            continue
        r = float(table.get(names[b], _DEFAULT_RADIUS))
        out.append(LinkCapsule(names[b], a, b, r, length))
        a = b
    return tuple(out)


def _poses(robot: Robot, q: FloatArray) -> dict[str, FloatArray]:
    from redservo.robots.afma6 import Afma6
    from redservo.robots.dh import DHRobot

    if not isinstance(robot, DHRobot | Afma6):
        raise ConfigurationError(
            f"robot {robot.name!r} has no built-in collision model (built-in: Afma6, "
            "Humanoid9, Panda and any DHRobot; a URDF robot uses its <collision> elements)",
            argument="robot",
        )
    return dict(robot.link_poses(q, check_limits=False))


def point_jacobians(robot: Robot, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The origins of every link frame and their velocity Jacobians, base frame.

    Returns:
        ``(O, J)``: (F, 3) origins (m) and (F, 3, n) Jacobians ``∂o/∂q`` (m/rad or m/m),
        frames in the order of ``robot.link_poses``.
    """
    own = getattr(robot, "collision_points", None)  # the ends of its own capsules (MJCF)
    if own is not None:
        O, J = own(q)
        return O, J
    poses = _poses(robot, q)
    O = np.stack([M[:3, 3] for M in poses.values()])
    if robot.name.lower() == "afma6":
        return O, _afma6_jacobians(robot, q, O.shape[0])
    chain: Any = robot._chain  # type: ignore[attr-defined]  # a DHRobot (see _poses)
    _, Z, P = chain(np.ascontiguousarray(q, dtype=np.float64))
    n = robot.n
    Z, P = np.asarray(Z)[:n], np.asarray(P)[:n]
    prismatic = np.array([t == "prismatic" for t in robot.joint_types])
    # Column j of frame k: z_j (prismatic) or z_j x (o_k - p_j), for the joints j < k only.
    cols = np.cross(Z[None, :, :], O[:, None, :] - P[None, :, :])  # (F, n, 3)
    cols[:, prismatic] = Z[prismatic]
    before = np.arange(n)[None, :] < np.arange(O.shape[0])[:, None]
    return O, np.ascontiguousarray(np.where(before[:, :, None], cols, 0.0).transpose(0, 2, 1))


def _afma6_jacobians(robot: Any, q: FloatArray, frames: int) -> FloatArray:
    """Frames base, x, y, z, A move with the first 0..3 prismatic joints; B and ee with the
    ee origin (``jacobe_base``)."""
    J = np.zeros((frames, 3, 6))
    for k, moving in enumerate((0, 1, 2, 3, 3)):
        J[k, :, :moving] = np.eye(3)[:, :moving]
    J[5:] = robot.jacobe_base(np.ascontiguousarray(q))[:3]
    return J
