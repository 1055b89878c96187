"""The compiled collision geometry of a run: when the kernels of
:mod:`redservo.kernels.loop_collide` can measure it, and its packs.

A set-up is compiled when the arm is a DH chain drawn as the segments between its link
frames (the Panda, any :class:`~redservo.robots.dh.DHRobot` with the base class's
kinematics; not an MJCF or URDF robot, whose geometry is their own) and every obstacle is
static. :class:`~redservo.control.avoidance.Collision` then measures with the kernels
(no coal call), and the compiled campaign loop takes the same packs, so the object path and
the loop get the same distances to the bit. Units: m.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from redservo.collision.pairs import self_pairs
from redservo.collision.robot import LinkCapsule, link_capsules
from redservo.collision.shapes import Obstacle
from redservo.robots.base import Robot
from redservo.scene import Static

__all__ = ["CompiledGeometry", "compiled_geometry", "geometry_reason"]

_KINDS = {"sphere": 0, "capsule": 1, "cylinder": 2, "box": 3, "plane": 4}
"""Obstacle kinds of :mod:`redservo.kernels.loop_collide`."""


class CompiledGeometry(NamedTuple):
    """The packs of :mod:`redservo.kernels.loop_collide` and the pairs' names and kinds."""

    arm: tuple[Any, ...]
    geom: tuple[Any, ...]
    names: tuple[str, ...]
    kinds: tuple[str, ...]

    def measure(self, q: Any) -> tuple[Any, Any]:
        """``(d (P,), J (P, n))`` at ``q`` (n,), rad or m (:func:`measure_arm`)."""
        from redservo.kernels.loop_collide import measure_arm

        qa = np.ascontiguousarray(q, dtype=np.float64)
        d, J, _, _ = measure_arm(qa, self.arm, self.geom)
        return np.asarray(d), np.asarray(J)

    def exact_scale(
        self, q: Any, qd: Any, d: Any, J: Any, sk: tuple[float, int], lim: tuple[float, ...]
    ) -> tuple[float, int]:
        """The shield's scale and pair ``sk`` checked on the geometry (:func:`exact_scale`);
        ``lim`` is ``(dt, d_safe, d_influence)`` (s, m, m)."""
        from redservo.kernels.loop_cull import exact_scale

        qa, qv = (np.ascontiguousarray(x, dtype=np.float64) for x in (q, qd))
        dt, d_safe, d_i = (float(x) for x in lim)
        s, k = float(sk[0]), int(sk[1])
        kept = (np.zeros(0), np.zeros(0), np.zeros((0, 0)), np.zeros(1, dtype=np.int64))
        none = (*kept, np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3, 0)))  # nothing kept
        out = exact_scale(qa, qv, d, J, s, k, dt, d_safe, d_i, self.arm, self.geom, none)
        return float(out[0]), int(out[1])


def geometry_reason(robot: Robot, obstacles: Sequence[Obstacle]) -> str | None:
    """Why the kernels cannot measure ``robot`` among ``obstacles`` (None: they can)."""
    from redservo.robots.dh import DHRobot

    if not isinstance(robot, DHRobot) or getattr(robot, "collision_points", None) is not None:
        return f"robot {robot.name!r}: no compiled collision geometry (DH chains only)"
    if type(robot).link_poses is not DHRobot.link_poses:
        return f"robot {robot.name!r}: its own link frames"
    for ob in obstacles:
        if not isinstance(ob.trajectory, Static):
            return f"obstacle {ob.name!r} moves (compiled: static obstacles only)"
    return None


def compiled_geometry(
    robot: Robot,
    obstacles: Sequence[Obstacle],
    self_collision: bool,
    capsules: Sequence[LinkCapsule] | None,
) -> CompiledGeometry | None:
    """The packs of ``robot`` (its capsules, default :func:`link_capsules`) among
    ``obstacles`` with or without the self pairs; None when :func:`geometry_reason` says no."""
    if geometry_reason(robot, obstacles) is not None:
        return None
    caps = tuple(capsules) if capsules is not None else link_capsules(robot)
    par, base, flange = robot._par, robot._base, robot._flange  # type: ignore[attr-defined]
    standard = robot._convention == "standard"  # type: ignore[attr-defined]
    arm = (par, np.ascontiguousarray(base), np.ascontiguousarray(flange), standard)
    index = {c.name: i for i, c in enumerate(caps)}
    pairs = self_pairs(caps) if self_collision else []
    kind = np.array([_KINDS[ob.shape.kind] for ob in obstacles], dtype=np.int64)
    size = np.zeros((len(obstacles), 3))
    for i, ob in enumerate(obstacles):
        sh = ob.shape
        size[i] = 0.5 * np.asarray(sh.size) if sh.kind == "box" else (sh.radius, sh.length, 0.0)
    geom = (
        np.array([(c.a, c.b) for c in caps], dtype=np.int64).reshape(len(caps), 2),
        np.array([c.radius for c in caps], dtype=np.float64),
        kind,
        np.array([ob.pose(0.0) for ob in obstacles], dtype=np.float64).reshape(-1, 4, 4),
        size,
        np.array([(index[a], index[b]) for a, b in pairs], dtype=np.int64).reshape(-1, 2),
    )
    names = [f"{c.name}/{ob.name}" for ob in obstacles for c in caps]
    names += [f"{a}/{b}" for a, b in pairs]
    kinds = ("environment",) * (len(caps) * len(obstacles)) + ("self",) * len(pairs)
    return CompiledGeometry(arm, geom, tuple(names), kinds)
