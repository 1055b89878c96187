"""Distances and their Jacobians for a :class:`~redservo.robots.URDFRobot`'s own
``<collision>`` elements (:func:`redservo.collision.urdf.urdf_collisions`).

Each element is posed at ``bMl(q) lMg`` (its link's pose from ``robot.link_poses``, its
``<origin>``) and its distance to each obstacle comes from coal, as the built-in robots'
capsules do (:mod:`redservo.collision.query`). The Jacobian of the witness point ``a``,
a point fixed on its link, is the central difference of its position over each joint
(step :data:`_STEP`, exact to ``O(h²)``; ``2n`` forward-kinematics calls per step, shared
by every element), so that any joint type and the file's joint order are handled as the
robot's own kinematics handle them; ``J_d = nᵀ J_p(a)``. Self pairs of URDF robots are not
available yet (one error naming ``self``). Units: m, rad.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.collision.shapes import Obstacle
from redservo.collision.urdf import UrdfCollision, urdf_collisions
from redservo.errors import ConfigurationError

__all__ = ["is_urdf", "urdf_distances", "urdf_elements"]

_STEP = 1e-6
"""Central-difference step (rad or m) of the witness points' Jacobians."""
_KEY = "_collision_elements"


def is_urdf(robot: object) -> bool:
    """Whether ``robot`` is a :class:`~redservo.robots.URDFRobot` (without importing it)."""
    return type(robot).__name__ == "URDFRobot" and hasattr(robot, "path")


def urdf_elements(robot: Any) -> tuple[UrdfCollision, ...]:
    """The robot's ``<collision>`` elements on its links (read once per robot).

    Raises:
        ConfigurationError: the file has none (``argument="robot"``).
        GeometryError: a mesh is missing, refused (outside the robot's folder) or unreadable.
    """
    hit = robot.__dict__.get(_KEY)
    if hit is not None:
        return hit
    links = set(robot.link_poses(robot.q_min / 2 + robot.q_max / 2, check_limits=False))
    elems = tuple(e for e in urdf_collisions(robot.path) if e.link in links)
    if not elems:
        raise ConfigurationError(
            f"robot {robot.name!r} has no built-in collision model and its URDF "
            f"{robot.path.name} has no <collision> elements on its links",
            argument="robot",
        )
    robot.__dict__[_KEY] = elems
    return elems


def urdf_distances(
    robot: Any,
    q: FloatArray,
    obstacles: Iterable[Obstacle],
    *,
    t: float = 0.0,
    self_collision: bool = False,
) -> list[Any]:
    """One :class:`~redservo.collision.query.DistanceRecord` per (element, obstacle) at
    ``q`` (rad or m) and ``t`` (s); ``first`` is the element's link."""
    from redservo.collision.pair import DistanceRecord, _normal, _query, _transform

    if self_collision:
        raise ConfigurationError(
            "self-collision pairs of URDF robots are not available yet; set self = false",
            argument="self",
        )
    elems = urdf_elements(robot)
    poses = robot.link_poses(q, check_limits=False)
    moved = []
    for i in range(robot.n):
        dq = np.zeros(robot.n)
        dq[i] = _STEP
        plus = robot.link_poses(q + dq, check_limits=False)
        minus = robot.link_poses(q - dq, check_limits=False)
        moved.append((plus, minus))
    out = []
    for ob in obstacles:
        geom, tf = ob.shape.coal(), _transform(ob.pose(t))
        for el in elems:
            M = poses[el.link] @ el.lMg
            d, a, b = _query(el.geometry, _transform(M), geom, tf)
            n = _normal(d, a, b, M[:3, 3] - b)
            local = np.linalg.solve(poses[el.link], np.append(a, 1.0))
            Ja = np.column_stack(
                [(p[el.link] @ local - m[el.link] @ local)[:3] / (2 * _STEP) for p, m in moved]
            )
            out.append(DistanceRecord(el.link, ob.name, "environment", d, a, b, n, n @ Ja))
    return out
