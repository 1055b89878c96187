"""Collision primitives and obstacles (world frame), and their `coal` geometries.

A :class:`Shape` is one primitive in its own frame, with the conventions of MuJoCo and
coal: ``sphere`` (``radius``), ``box`` (``size`` = full extents along x, y, z), ``capsule``
and ``cylinder`` (``radius``, ``length`` = the length of the axis segment along z, centred
on the origin; a capsule adds the two hemispherical caps), ``plane`` (the plane z = 0 of its
frame, the solid half-space z ≤ 0 below it: a table top is a plane whose frame sits on the
top surface, z up). All lengths in metres.

An :class:`Obstacle` is a named shape moving along a :class:`~redservo.scene.Trajectory`
(``wMo(t)``, world = robot base frame), like the scene objects.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Final, Literal

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import GeometryError
from redservo.scene import Static, Trajectory

__all__ = ["SHAPES", "Obstacle", "Shape", "ShapeKind"]

ShapeKind = Literal["sphere", "box", "capsule", "cylinder", "plane"]
SHAPES: Final[tuple[str, ...]] = ("sphere", "box", "capsule", "cylinder", "plane")
"""The primitive kinds, by name."""

_NEEDS: Final[dict[str, tuple[str, ...]]] = {
    "sphere": ("radius",),
    "box": ("size",),
    "capsule": ("radius", "length"),
    "cylinder": ("radius", "length"),
    "plane": (),
}
"""The sizes each kind needs (the others must be absent)."""


def needed_sizes(kind: str) -> tuple[str, ...]:
    """The size keys (``radius``, ``size``, ``length``) a shape kind needs."""
    return _NEEDS[kind]


@dataclass(frozen=True)
class Shape:
    """One primitive in its own frame (module docstring; sizes in m).

    Raises:
        GeometryError: unknown kind, a missing size, or a size that is not finite and > 0.
    """

    kind: str
    radius: float = 0.0
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    length: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in _NEEDS:
            raise GeometryError(f"shape: unknown shape {self.kind!r}; allowed: {', '.join(SHAPES)}")
        values = {"radius": [self.radius], "size": list(self.size), "length": [self.length]}
        for key in _NEEDS[self.kind]:
            if not all(np.isfinite(v) and v > 0.0 for v in values[key]):
                raise GeometryError(f"{key}: a {self.kind} needs {key} > 0 (m), got {values[key]}")

    def coal(self) -> Any:
        """The `coal` collision geometry of this shape."""
        import coal

        if self.kind == "sphere":
            return coal.Sphere(self.radius)
        if self.kind == "box":
            return coal.Box(*self.size)
        if self.kind == "capsule":
            return coal.Capsule(self.radius, self.length)
        if self.kind == "cylinder":
            return coal.Cylinder(self.radius, self.length)
        return coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)


@dataclass(frozen=True, eq=False)
class Obstacle:
    """A named :class:`Shape` moving along ``trajectory`` (default: static at the origin)."""

    name: str
    shape: Shape
    trajectory: Trajectory = field(default_factory=lambda: Static(np.eye(4)))

    def pose(self, t: float = 0.0) -> FloatArray:
        """``wMo`` (4x4, m) at time ``t`` (s)."""
        return self.trajectory.pose(t)
