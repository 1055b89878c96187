"""Schema of ``[[obstacles]]``: named primitives the robot must not touch.

An obstacle has a ``shape`` (``sphere``, ``box``, ``capsule``, ``cylinder``, ``plane``;
:mod:`redservo.collision.shapes` gives the conventions), the sizes that shape needs and no
others, a start ``pose`` in the world frame (the same syntax as the objects' poses) and an
optional ``motion`` (the same kinds as the objects'). Example::

    [[obstacles]]
    name = "post"
    shape = "cylinder"
    radius = 0.02
    length = 0.8
    pose = { translation = [0.4, 0.1, 0.4] }
"""

from __future__ import annotations

from pydantic import Field, model_validator

from redservo.collision.shapes import SHAPES, Obstacle, Shape, needed_sizes
from redservo.schema.base import BIG, Table, Vec3, fail, num, unknown_name
from redservo.schema.scene import AnyMotion, Pose

__all__ = ["CollisionSpec", "ObstacleSpec", "OcclusionSpec"]

_SIZES = ("radius", "size", "length")


class OcclusionSpec(Table):
    """An occluding sphere that may hide a points target (MC05 experiment 2)."""

    occluder: str = Field(description="a sphere object")
    target: str = Field(description="the points object it may hide")
    beta: float = num(50.0, gt=0.0, le=1e6, description="β of V = exp(−β d²) (MC05 eq. 30)")
    gain: float = num(1.0, ge=0.0, le=BIG, description="scale of the artificial force")
    avoid: bool = Field(True, description="false: detect only")


class ObstacleSpec(Table):
    """An obstacle the robot must not touch: a primitive posed in the world frame. Sizes in m:
    a sphere takes `radius`; a box `size` (full extents); a capsule or a cylinder `radius`
    and `length` (its axis, along its z, centred on its origin); a plane none (the plane
    z = 0 of its pose, solid below: a table top). See docs/collision.md."""

    name: str = Field(min_length=1, max_length=100, description="unique name")
    shape: str = Field(
        description="sphere, box, capsule, cylinder or plane",
        json_schema_extra={"enum": list(SHAPES)},
    )
    radius: float | None = num(
        None, gt=0.0, le=BIG, description="sphere, capsule, cylinder: radius (m)"
    )
    size: Vec3 | None = Field(None, description="box: full extents along its x, y, z (m), each > 0")
    length: float | None = num(
        None, gt=0.0, le=BIG, description="capsule, cylinder: length of the axis (along z, m)"
    )
    pose: Pose | None = Field(None, description="start pose in the world frame (default origin)")
    motion: AnyMotion | None = Field(None, description="motion (default static)")

    @model_validator(mode="after")
    def _sizes(self) -> ObstacleSpec:
        if self.shape not in SHAPES:
            fail(unknown_name("shape", self.shape, SHAPES), "shape")
        needs = needed_sizes(self.shape)
        for key in _SIZES:
            given = getattr(self, key) is not None
            if key in needs and not given:
                fail(f"a {self.shape} needs {key}", key)
            if key not in needs and given:
                fail(f"a {self.shape} takes no {key} (it takes: {', '.join(needs) or 'none'})", key)
        if self.size is not None and min(self.size) <= 0.0:
            fail(f"every extent must be > 0 (m), got {self.size}", "size")
        return self

    def obstacle(self) -> Obstacle:
        """The runtime :class:`~redservo.collision.shapes.Obstacle`."""
        import numpy as np

        from redservo.scene import Static

        wMo0 = self.pose.matrix() if self.pose is not None else np.eye(4)
        traj = self.motion.trajectory(wMo0) if self.motion is not None else Static(wMo0)
        shape = Shape(
            self.shape,
            radius=self.radius or 0.0,
            size=tuple(self.size) if self.size is not None else (0.0, 0.0, 0.0),  # type: ignore[arg-type]
            length=self.length or 0.0,
        )
        return Obstacle(self.name, shape, traj)


class CollisionSpec(Table):
    """Collision avoidance against the `[[obstacles]]` (and, with `self`, the robot's own
    links): a repulsive joint velocity in the law's secondary term for every pair closer than
    `d_influence`, velocity-damper rows inside `qp`, `sns` and `predictive`, and the
    distance shield, which scales the command so that no pair comes
    closer than `d_safe` within one period (flag distance-shield-acted). Without this table
    (or with `enabled = false`) the obstacles are only measured: a run that touches one ends
    with outcome `collision`. See docs/collision.md."""

    enabled: bool = Field(True, description="avoid and shield; false: measure only")
    d_safe: float = num(
        0.02, ge=0.0, le=BIG, description="security distance (m): no pair ever closer"
    )
    d_influence: float = num(
        0.10, gt=0.0, le=BIG, description="influence distance (m): avoidance starts, > d_safe"
    )
    self: bool = Field(False, description="also the robot's self pairs")
    srdf: str | None = Field(
        None,
        description="a URDF robot's SRDF file (relative to the scenario): its "
        "<disable_collisions> pairs are not checked for self-collision",
    )
    xi: float = num(0.05, gt=0.0, le=BIG, description="separating speed asked for at d_safe (m/s)")
    avoid: bool = Field(
        True, description="avoid: the repulsive secondary term and the qp/sns/predictive rows"
    )
    repel: bool = Field(True, description="with avoid, the repulsive term (false: rows only)")
    shield: bool = Field(True, description="the distance shield")

    @model_validator(mode="after")
    def _distances(self) -> CollisionSpec:
        if self.d_influence <= self.d_safe:
            fail(f"must be > d_safe = {self.d_safe:g} m, got {self.d_influence:g} m", "d_influence")
        return self
