"""Distances and their Jacobians for a :class:`~redservo.robots.URDFRobot`'s own
``<collision>`` elements (:func:`redservo.collision.urdf.urdf_collisions`).

Each element is posed at ``bMl(q) lMg`` (its link's pose from ``robot.link_poses``, its
``<origin>``) and its distance to each obstacle comes from coal, as the built-in robots'
capsules do (:mod:`redservo.collision.query`). The Jacobian of the witness point ``a``,
a point fixed on its link, is the central difference of its position over each joint
(step :data:`_STEP`, exact to ``O(h²)``; ``2n`` forward-kinematics calls per step, shared
by every element), so that any joint type and the file's joint order are handled as the
robot's own kinematics handle them; ``J_d = nᵀ J_p(a)``. A self pair (two elements on links
:func:`redservo.collision.urdf_pairs.urdf_self_pairs` keeps: not one rigid body, not
adjacent, not disabled by the robot's SRDF or the caller) has witness points on both links:
``J_d = nᵀ (J_p(a) − J_p(b))``. Units: m, rad.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.collision.shapes import Obstacle
from redservo.collision.urdf import UrdfCollision, urdf_collisions
from redservo.collision.urdf_pairs import urdf_self_pairs
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
    srdf: str | Path | None = None,
    exclude: Iterable[tuple[str, str]] = (),
) -> list[Any]:
    """One :class:`~redservo.collision.query.DistanceRecord` per (element, obstacle) at
    ``q`` (rad or m) and ``t`` (s), then, with ``self_collision``, one per pair of elements
    on a self pair of links (``srdf`` and ``exclude`` as
    :func:`~redservo.collision.urdf_pairs.urdf_self_pairs`); ``first`` is the element's
    link, ``second`` the obstacle or the other link."""
    from redservo.collision.pair import DistanceRecord, _normal, _query, _transform

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
            Ja = _point_jacobian(poses, moved, el.link, a)
            out.append(DistanceRecord(el.link, ob.name, "environment", d, a, b, n, n @ Ja))
    if self_collision:
        pairs = _self_pairs(robot, elems, srdf, tuple(exclude))
        for i, e1 in enumerate(elems):
            for e2 in elems[i + 1 :]:
                if (e1.link, e2.link) not in pairs and (e2.link, e1.link) not in pairs:
                    continue
                M1, M2 = poses[e1.link] @ e1.lMg, poses[e2.link] @ e2.lMg
                d, a, b = _query(e1.geometry, _transform(M1), e2.geometry, _transform(M2))
                n = _normal(d, a, b, M1[:3, 3] - b)
                Jd = n @ (
                    _point_jacobian(poses, moved, e1.link, a)
                    - _point_jacobian(poses, moved, e2.link, b)
                )
                out.append(DistanceRecord(e1.link, e2.link, "self", d, a, b, n, Jd))
    return out


def _self_pairs(
    robot: Any, elems: tuple[UrdfCollision, ...], srdf: str | Path | None, exclude: tuple[Any, ...]
) -> frozenset[tuple[str, str]]:
    """The robot's self pairs of links, read once per ``(srdf, exclude)`` and kept on it."""
    cache = robot.__dict__.setdefault("_collision_self_pairs", {})
    key = (None if srdf is None else str(srdf), exclude)
    if key not in cache:
        links = [e.link for e in elems]
        pairs = urdf_self_pairs(robot.path, links, srdf=srdf, exclude=exclude)
        cache[key] = frozenset(pairs)
    return cache[key]


def _point_jacobian(
    poses: dict[str, Any], moved: list[Any], link: str, p: FloatArray
) -> FloatArray:
    """(3, n) central-difference Jacobian (m/rad or m/m) of the point ``p`` (base frame, m)
    fixed on ``link``."""
    local = np.linalg.solve(poses[link], np.append(p, 1.0))
    return np.column_stack(
        [(pl[link] @ local - mi[link] @ local)[:3] / (2 * _STEP) for pl, mi in moved]
    )
