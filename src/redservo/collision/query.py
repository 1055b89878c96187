"""Distances between the robot's capsules, the obstacles and each other, with Jacobians.

:func:`distances` is the user-facing query. Each :class:`DistanceRecord` holds the signed
distance ``d`` (m, negative when the shapes overlap: the penetration depth), the witness
points ``a`` (on the first shape) and ``b`` (on the second), the unit normal ``n`` from
``b`` towards ``a`` and the Jacobian ``J_d = nᵀ (J_p(a) − J_p(b))`` (1/n, m per rad or m per
m of each joint): ``ḋ = J_d q̇`` for a static obstacle. ``J_p`` of a witness point is the
velocity of the point of the capsule's axis nearest to it (the rest, ``ω × r n``, is normal
to ``n`` and adds nothing to ``ḋ``). Distances come from `coal` (docs/decisions.md).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from redservo._validation import FloatArray
from redservo.collision.pair import DistanceRecord, PairKind, _normal, _query, _transform
from redservo.collision.pairs import self_pairs
from redservo.collision.robot import LinkCapsule, link_capsules, point_jacobians
from redservo.collision.shapes import Obstacle
from redservo.collision.urdf_query import is_urdf, urdf_distances
from redservo.robots.base import Robot

__all__ = ["DistanceRecord", "distances"]


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a × b`` of two 3-vectors (numpy's formula, without its broadcasting overhead)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def _capsule_frame(A: FloatArray, B: FloatArray) -> FloatArray:
    """A frame at the segment's middle whose z axis runs from ``A`` to ``B``."""
    z = (B - A) / np.linalg.norm(B - A)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = _cross(helper, z)
    x /= np.linalg.norm(x)
    M = np.eye(4)
    M[:3, :3] = np.column_stack([x, _cross(z, x), z])
    M[:3, 3] = 0.5 * (A + B)
    return M


class _Link:
    """A capsule posed at q: its coal geometry and the Jacobian of its axis points."""

    def __init__(self, cap: LinkCapsule, O: FloatArray, J: FloatArray) -> None:
        import coal

        self.cap = cap
        self.A, self.B = O[cap.a], O[cap.b]
        self.JA, self.JB = J[cap.a], J[cap.b]
        self.length = float(np.linalg.norm(self.B - self.A))
        self.geom = coal.Capsule(cap.radius, self.length)
        self.tf = _transform(_capsule_frame(self.A, self.B))

    def jacobian(self, p: FloatArray) -> FloatArray:
        """(3, n) velocity of the axis point nearest to ``p``."""
        s = float(np.clip(np.dot(p - self.A, self.B - self.A) / self.length**2, 0.0, 1.0))
        return np.asarray((1.0 - s) * self.JA + s * self.JB)


def distances(
    robot: Robot,
    q: Sequence[float] | FloatArray,
    obstacles: Iterable[Obstacle] = (),
    *,
    t: float = 0.0,
    self_collision: bool = False,
    capsules: Sequence[LinkCapsule] | None = None,
    exclude: Iterable[tuple[str, str]] = (),
    srdf: str | Path | None = None,
) -> list[DistanceRecord]:
    """Every robot-obstacle pair (and self pair) at configuration ``q`` and time ``t``.

    Example::

        >>> from redservo.collision import Obstacle, Shape, distances
        >>> from redservo.robots import make_robot
        >>> from redservo.scene import Static
        >>> from redservo.spatial import make_transform
        >>> robot = make_robot("panda")
        >>> post = Obstacle("post", Shape("cylinder", radius=0.02, length=1.0),
        ...                 Static(make_transform(t=(0.3, 0.3, 0.5))))
        >>> rec = min(distances(robot, robot.ready_configuration(), [post]),
        ...           key=lambda r: r.distance)
        >>> rec.second, rec.jacobian.shape
        ('post', (7,))

    Args:
        robot: A built-in model (see :func:`~redservo.collision.robot.link_capsules`), or a
            URDF robot with ``<collision>`` elements (:mod:`~redservo.collision.urdf_query`).
        q: (n,) joint positions (rad or m); not checked against the limits.
        obstacles: The obstacles (world = base frame).
        t: Time (s) at which the obstacles are posed.
        self_collision: Also the self pairs of :func:`~redservo.collision.pairs.self_pairs`.
        capsules: The robot's capsules (default :func:`link_capsules`).
        exclude: More self pairs to skip, as (link, link) names.
        srdf: A URDF robot's SRDF file: its ``<disable_collisions>`` pairs are skipped
            (:func:`~redservo.collision.urdf_pairs.urdf_self_pairs`).

    Returns:
        One record per pair: every link against every obstacle, then the self pairs.
    """
    qa = robot.check_q(q, check_limits=False)
    if capsules is None and is_urdf(robot):  # its own <collision> elements
        return list(
            urdf_distances(
                robot, qa, obstacles, t=t, self_collision=self_collision, srdf=srdf, exclude=exclude
            )
        )
    caps = tuple(capsules) if capsules is not None else link_capsules(robot)
    O, J = point_jacobians(robot, qa)
    links = [_Link(c, O, J) for c in caps]
    zero = np.zeros((3, robot.n))
    out = []
    for ob in obstacles:
        geom, tf = ob.shape.coal(), _transform(ob.pose(t))
        for link in links:
            d, a, b = _query(link.geom, link.tf, geom, tf)
            out.append(_record(link, None, ob.name, "environment", d, a, b, zero))
    if self_collision:
        by_name = {link.cap.name: link for link in links}
        for n1, n2 in self_pairs(caps, exclude):
            l1, l2 = by_name[n1], by_name[n2]
            d, a, b = _query(l1.geom, l1.tf, l2.geom, l2.tf)
            out.append(_record(l1, l2, n2, "self", d, a, b, zero))
    return out


def _record(
    link: _Link,
    other: _Link | None,
    name: str,
    kind: PairKind,
    d: float,
    a: FloatArray,
    b: FloatArray,
    zero: FloatArray,
) -> DistanceRecord:
    n = _normal(d, a, b, (link.A + link.B) / 2 - b)
    Jb = zero if other is None else other.jacobian(b)
    Jd = n @ (link.jacobian(a) - Jb)
    return DistanceRecord(link.cap.name, name, kind, d, a, b, n, np.asarray(Jd))
