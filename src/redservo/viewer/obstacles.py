"""``[[obstacles]]`` in the 3-D viewer: viser primitives, orange, posed at ``wMo(t)``.

A sphere is an icosphere, a box a box of its full extents, a cylinder a closed cylinder
mesh, a capsule a cylinder mesh and two icospheres (its caps), a plane a 2 m square, 1 mm
thick, whose top face is the plane. Each handle is kept with its pose in the obstacle's
frame (:func:`place_obstacles` moves moving obstacles at each frame). Units: metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.collision.shapes import Obstacle
from redservo.spatial import make_transform
from redservo.viewer.meshes import cylinder_mesh
from redservo.viewer.surfaces import _wxyz

__all__ = ["OBSTACLE_COLOR", "PLANE_SIDE", "add_obstacles", "place_obstacles"]

OBSTACLE_COLOR = (217, 115, 26)
"""RGB of the obstacles (the MuJoCo paint, :data:`redservo.physics.obstacles.OBSTACLE_RGBA`)."""
PLANE_SIDE = 2.0
"""Side (m) of the square drawn for a plane."""

Placed = tuple[Any, Obstacle, FloatArray]
"""A viser handle, its obstacle and the handle's pose in the obstacle frame (4x4)."""


def _parts(server: Any, path: str, ob: Obstacle) -> list[tuple[Any, FloatArray]]:
    s, scene, c = ob.shape, server.scene, OBSTACLE_COLOR
    if s.kind == "sphere":
        return [(scene.add_icosphere(path, radius=s.radius, color=c), np.eye(4))]
    if s.kind == "box":
        return [(scene.add_box(path, color=c, dimensions=s.size), np.eye(4))]
    if s.kind == "plane":
        dims = (PLANE_SIDE, PLANE_SIDE, 1e-3)
        box = scene.add_box(path, color=c, dimensions=dims, opacity=0.5)
        return [(box, make_transform(t=(0.0, 0.0, -0.5e-3)))]
    v, f = cylinder_mesh(s.radius, s.length)
    out = [(scene.add_mesh_simple(f"{path}/body", v, f, color=c), np.eye(4))]
    if s.kind == "capsule":
        for end, z in (("top", 0.5), ("bottom", -0.5)):
            cap = scene.add_icosphere(f"{path}/{end}", radius=s.radius, color=c)
            out.append((cap, make_transform(t=(0.0, 0.0, z * s.length))))
    return out


def add_obstacles(server: Any, obstacles: Sequence[Obstacle], t: float = 0.0) -> list[Placed]:
    """Add every obstacle to ``server.scene`` under ``/obstacles/NAME``, posed at ``t`` (s)."""
    out = [
        (handle, ob, offset)
        for ob in obstacles
        for handle, offset in _parts(server, f"/obstacles/{ob.name}", ob)
    ]
    place_obstacles(out, t)
    return out


def place_obstacles(placed: Sequence[Placed], t: float) -> None:
    """Move the handles to their obstacles' poses at time ``t`` (s)."""
    for handle, ob, offset in placed:
        T = ob.pose(t) @ offset
        handle.position = T[:3, 3]
        handle.wxyz = _wxyz(T[:3, :3])


# --------------------------------------------------------------------------- animate's 3-D panel


def _circle(radius: float, z: float, axis: int = 2, n: int = 33) -> FloatArray:
    """A closed circle of ``radius`` (m) about the ``axis`` through (0, 0, z), then a NaN."""
    a = np.linspace(0.0, 2.0 * np.pi, n)
    c, s = radius * np.cos(a), radius * np.sin(a)
    pts = {2: (c, s, np.full(n, z)), 0: (np.full(n, z), c, s), 1: (c, np.full(n, z), s)}[axis]
    return np.vstack([np.stack(pts, axis=1), np.full((1, 3), np.nan)])


def outline(ob: Obstacle) -> FloatArray:
    """(N, 3) polylines (NaN-separated) tracing the shape in its own frame (m)."""
    s = ob.shape
    if s.kind == "sphere":
        return np.vstack([_circle(s.radius, 0.0, axis) for axis in (0, 1, 2)])
    if s.kind in ("box", "plane"):
        h = 0.5 * np.array(s.size if s.kind == "box" else (PLANE_SIDE, PLANE_SIDE, 0.0))
        sq = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]], dtype=float)
        top = np.hstack([sq * h[:2], np.full((5, 1), h[2])])
        bottom = top * [1.0, 1.0, -1.0]
        posts = [np.vstack([top[i], bottom[i], np.full(3, np.nan)]) for i in range(4)]
        return np.vstack([top, np.full((1, 3), np.nan), bottom, np.full((1, 3), np.nan), *posts])
    half = 0.5 * s.length
    lines = [_circle(s.radius, half), _circle(s.radius, -half)]
    for x, y in ((1, 0), (0, 1), (-1, 0), (0, -1)):
        p = s.radius * np.array([x, y, 0.0])
        dz = np.array([0.0, 0.0, half])
        lines.append(np.array([p + dz, p - dz, [np.nan] * 3]))
    if s.kind == "capsule":
        a = np.linspace(0.0, np.pi, 17)
        for sign in (1.0, -1.0):
            arc = np.stack([s.radius * np.cos(a), 0 * a, sign * (half + s.radius * np.sin(a))], 1)
            lines += [arc, np.full((1, 3), np.nan), arc[:, [1, 0, 2]], np.full((1, 3), np.nan)]
    return np.vstack(lines)


def posed_outline(ob: Obstacle, t: float) -> FloatArray:
    """:func:`outline` in the world frame at time ``t`` (s)."""
    T = ob.pose(t)
    return np.asarray(outline(ob) @ T[:3, :3].T + T[:3, 3])
