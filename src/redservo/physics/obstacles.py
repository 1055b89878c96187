"""``[[obstacles]]`` as MuJoCo geoms: one mocap body per obstacle, one native primitive each.

MuJoCo's primitives match :mod:`redservo.collision.shapes` with half sizes: a sphere's
``size`` is its radius, a box's its half extents, a capsule's and a cylinder's the radius
and half the axis length (both along the body's z), and a plane (infinite, ``size="0 0
1"``) is the plane z = 0 of its body, normal +z. The geoms have MuJoCo's default collision
flags off like the rest of the model (``contype = conaffinity = 0``: the arm is driven
kinematically) but exist for :func:`mujoco.mj_geomDistance` and are drawn in the rendered
images (so an obstacle can hide the target from the camera). Units: metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from redservo.collision.shapes import Obstacle, Shape
from redservo.physics.mjcf import _vec, xml_pose

__all__ = ["OBSTACLE_RGBA", "obstacle_bodies", "obstacle_geom", "set_obstacle_poses"]

OBSTACLE_RGBA = "0.85 0.45 0.1 1"
"""Paint of the obstacles: opaque orange, unlike every target (dark or paper white)."""


def obstacle_geom(name: str, shape: Shape) -> str:
    """The ``<geom>`` of ``shape`` in its own frame, named ``obs:NAME``."""
    kind = shape.kind
    if kind == "sphere":
        size = _vec(np.array([shape.radius]))
    elif kind == "box":
        size = _vec(0.5 * np.array(shape.size))
    elif kind in ("capsule", "cylinder"):
        size = _vec(np.array([shape.radius, 0.5 * shape.length]))
    else:
        size = "0 0 1"
    return f'<geom name="obs:{name}" type="{kind}" size="{size}" rgba="{OBSTACLE_RGBA}"/>'


def obstacle_bodies(obstacles: Sequence[Obstacle]) -> str:
    """Mocap bodies ``obs:NAME`` at ``wMo(0)`` holding each obstacle's geom."""
    return "".join(
        f'<body name="obs:{o.name}" mocap="true" {xml_pose(o.pose(0.0))}>'
        f"{obstacle_geom(o.name, o.shape)}</body>"
        for o in obstacles
    )


def set_obstacle_poses(model: Any, data: Any, obstacles: Sequence[Obstacle], t: float) -> None:
    """Move the obstacles' mocap bodies to ``wMo(t)`` (t in s)."""
    from scipy.spatial.transform import Rotation

    for o in obstacles:
        k = int(model.body_mocapid[model.body(f"obs:{o.name}").id])
        wMo = o.pose(t)
        data.mocap_pos[k] = wMo[:3, 3]
        x, y, z, w = Rotation.from_matrix(wMo[:3, :3]).as_quat()
        data.mocap_quat[k] = (w, x, y, z)
