"""Schema of the scene part of a scenario: poses, object motions and objects.

Each object kind (and motion kind) is one :class:`~redservo.schema.base.Table` with a
``kind`` literal, its keys (types, ranges, defaults, units) and the method that builds the
runtime object from it (:meth:`ObjectSpec.scene_object`, :mod:`redservo.scene`). A new
kind is its runtime class in its own module plus one spec class here, listed in
:data:`OBJECT_KINDS`. Features: :mod:`redservo.schema.features`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from redservo._validation import FloatArray
from redservo.scene import SceneObject, Trajectory
from redservo.schema.base import BIG, Doc, Table, Vec3, fail, num, tagged_union

__all__ = ["MOTION_KINDS", "OBJECT_KINDS", "AnyMotion", "AnyObject", "ObjectSpec", "Pose"]


class Pose(Table):
    """A rigid transform: translation (m) and rotation (rotation vector, rad, or roll-pitch-yaw,
    degrees; give at most one of the two)."""

    translation: Vec3 = Field([0.0, 0.0, 0.0], description="translation (m)")
    rotvec: Vec3 | None = Field(None, description="rotation vector, axis times angle (rad)")
    rpy_deg: Vec3 | None = Field(
        None, description="roll, pitch, yaw (deg): R = Rz(yaw) Ry(pitch) Rx(roll)"
    )

    @model_validator(mode="after")
    def _one_rotation(self) -> Pose:
        if self.rotvec is not None and self.rpy_deg is not None:
            fail("give either rotvec or rpy_deg, not both", "rpy_deg")
        return self

    def matrix(self) -> FloatArray:
        """The 4x4 homogeneous transform."""
        from redservo.spatial import make_transform, rpy_to_matrix

        if self.rpy_deg is not None:
            return make_transform(rpy_to_matrix(self.rpy_deg, degrees=True), self.translation)
        return make_transform(t=self.translation, rotvec=self.rotvec or [0.0, 0.0, 0.0])


# --------------------------------------------------------------------------- motions


class StaticMotion(Table):
    """The object does not move (the default)."""

    kind: Literal["static"] = "static"

    def trajectory(self, wMo0: FloatArray) -> Trajectory:
        """The runtime trajectory from the start pose ``wMo0`` (4x4)."""
        from redservo.scene import Static

        return Static(wMo0)


class ConstantVelocityMotion(Table):
    """Constant linear and angular velocity, world frame, from the start pose."""

    kind: Literal["constant_velocity"]
    velocity: Vec3 = Field([0.0, 0.0, 0.0], description="velocity of the origin (m/s)")
    angular_velocity: Vec3 = Field([0.0, 0.0, 0.0], description="angular velocity (rad/s)")

    def trajectory(self, wMo0: FloatArray) -> Trajectory:
        """The runtime trajectory from the start pose ``wMo0`` (4x4)."""
        from redservo.scene import ConstantVelocity

        return ConstantVelocity(wMo0, np.array(self.velocity), np.array(self.angular_velocity))


_Time = Annotated[float, Field(ge=0.0, le=1e7, allow_inf_nan=False)]


class WaypointsMotion(Table):
    """Timed world-frame offsets of the object origin (and rotations about it)."""

    kind: Literal["waypoints"]
    times: Annotated[list[_Time], Doc("array of numbers >= 0, increasing")] = Field(
        min_length=1, max_length=100_000, description="times of the waypoints (s)"
    )
    translations: list[Vec3] = Field(
        min_length=1, max_length=100_000, description="offsets of the origin (m), one per time"
    )
    rotvecs: list[Vec3] | None = Field(
        None, description="rotations about the origin (rad), one per time (default none)"
    )

    @model_validator(mode="after")
    def _consistent(self) -> WaypointsMotion:
        k = len(self.times)
        if any(b <= a for a, b in zip(self.times, self.times[1:])):
            fail(f"times must be strictly increasing, got {self.times}", "times")
        for key in ("translations", "rotvecs"):
            value = getattr(self, key)
            if value is not None and len(value) != k:
                fail(f"expected {k} entries (one per time), got {len(value)}", key)
        return self

    def trajectory(self, wMo0: FloatArray) -> Trajectory:
        """The runtime trajectory from the start pose ``wMo0`` (4x4)."""
        from redservo.scene import Waypoints
        from redservo.spatial import make_transform

        k = len(self.times)
        rv = np.zeros((k, 3)) if self.rotvecs is None else np.array(self.rotvecs)
        poses = np.stack([np.eye(4)] * k)
        for i in range(k):
            poses[i][:3, :3] = make_transform(rotvec=rv[i])[:3, :3] @ wMo0[:3, :3]
            poses[i][:3, 3] = wMo0[:3, 3] + np.asarray(self.translations[i])
        return Waypoints(np.array(self.times), poses)


MOTION_KINDS: dict[str, type[Table]] = {
    "static": StaticMotion,
    "constant_velocity": ConstantVelocityMotion,
    "waypoints": WaypointsMotion,
}
"""Motion kinds of ``[objects.motion]``, by ``kind`` (one entry per kind)."""
if TYPE_CHECKING:
    AnyMotion = StaticMotion | ConstantVelocityMotion | WaypointsMotion
else:
    AnyMotion = tagged_union(MOTION_KINDS, default="static", what="motion kind")


# --------------------------------------------------------------------------- objects


class ObjectSpec(Table):
    """Keys every object has. The start pose is ``pose`` (world frame) or ``pose_in_camera``
    (relative to the start camera), default the world origin."""

    kind: str
    name: str = Field(
        min_length=1, max_length=100, description="unique name (features refer to it)"
    )
    pose: Pose | None = Field(None, description="start pose in the world (= robot base) frame")
    pose_in_camera: Pose | None = Field(None, description="start pose in the start camera frame")
    pose_in_effector: Pose | None = Field(
        None, description="camera.mount = world: the object's pose eMo on the end effector"
    )
    motion: AnyMotion | None = Field(None, description="motion (default static)")

    @model_validator(mode="after")
    def _one_pose(self) -> ObjectSpec:
        if self.pose is not None and self.pose_in_camera is not None:
            fail("give either pose or pose_in_camera, not both", "pose_in_camera")
        if self.pose_in_effector is not None and "pose" in self.model_fields_set:
            fail("give either pose or pose_in_effector, not both", "pose_in_effector")
        if self.pose_in_effector is not None and self.pose_in_camera is not None:
            fail("give either pose_in_camera or pose_in_effector, not both", "pose_in_effector")
        return self

    def scene_object(self, trajectory: Trajectory) -> SceneObject:  # pragma: no cover - abstract
        """The runtime :class:`~redservo.scene.SceneObject` moving along ``trajectory``."""
        raise NotImplementedError

    def reference_points(self) -> FloatArray:
        """(N, 3) points (object frame, m) that must stay in the image."""
        return np.zeros((1, 3))


class PointsObject(ObjectSpec):
    """Points fixed in the object frame (e.g. the dots of a planar target)."""

    kind: Literal["points"]
    points: list[Vec3] = Field(
        [[0.0, 0.0, 0.0]], min_length=1, max_length=10_000, description="(N, 3) points (m)"
    )

    def scene_object(self, trajectory: Trajectory) -> SceneObject:
        """The runtime :class:`~redservo.scene.PointSet`."""
        from redservo.scene import PointSet

        return PointSet(self.name, np.array(self.points, dtype=float), trajectory=trajectory)

    def reference_points(self) -> FloatArray:
        return np.array(self.points, dtype=float)


class TagObject(ObjectSpec):
    """A square fiducial tag (AprilTag or ArUco): its four corners are its points, in ViSP's
    tag frame (z out of the printed face; :class:`~redservo.scene.Tag`)."""

    kind: Literal["tag"]
    family: str = Field("36h11", description="tag family: 36h11, 25h9, 16h5, aruco_4x4_50...")
    id: int = Field(0, ge=0, le=100_000, description="tag id in its family (0-based)")
    size: float = num(0.05, gt=0.0, le=BIG, description="side of the black square (m)")

    @model_validator(mode="after")
    def _known(self) -> TagObject:
        from redservo.errors import RedservoError
        from redservo.vision.tag_families import check_tag

        try:
            check_tag(self.family, self.id)
        except RedservoError as exc:
            fail(str(exc), "id" if "id" in str(exc).split(" ")[1:2] else "family")
        return self

    def scene_object(self, trajectory: Trajectory) -> SceneObject:
        """The runtime :class:`~redservo.scene.Tag`."""
        from redservo.scene import Tag

        return Tag(
            self.name, size=self.size, tag_id=self.id, family=self.family, trajectory=trajectory
        )

    def reference_points(self) -> FloatArray:
        h = 0.5 * self.size
        return np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])


_Radius = num(0.05, gt=0.0, le=BIG, description="radius (m)")


class SphereObject(ObjectSpec):
    """A sphere."""

    kind: Literal["sphere"]
    radius: float = _Radius
    center: Vec3 = Field([0.0, 0.0, 0.0], description="centre in the object frame (m)")

    def scene_object(self, trajectory: Trajectory) -> SceneObject:
        """The runtime :class:`~redservo.scene.Sphere`."""
        from redservo.scene import Sphere

        return Sphere(self.name, self.radius, np.array(self.center), trajectory=trajectory)

    def reference_points(self) -> FloatArray:
        return np.array([self.center], dtype=float)


def _nonzero(v: list[float], key: str) -> None:
    if float(np.linalg.norm(v)) < 1e-9:
        fail(f"must not be the zero vector, got {v}", key)


class CylinderObject(ObjectSpec):
    """An infinite cylinder around the line through ``point`` along ``axis``."""

    kind: Literal["cylinder"]
    radius: float = _Radius
    axis: Vec3 = Field([0.0, 1.0, 0.0], description="axis direction, object frame (non-zero)")
    point: Vec3 = Field([0.0, 0.0, 0.0], description="a point of the axis, object frame (m)")

    @model_validator(mode="after")
    def _axis(self) -> CylinderObject:
        _nonzero(self.axis, "axis")
        return self

    def scene_object(self, trajectory: Trajectory) -> SceneObject:
        """The runtime :class:`~redservo.scene.Cylinder`."""
        from redservo.scene import Cylinder

        return Cylinder(
            self.name, self.radius, np.array(self.axis), np.array(self.point), trajectory=trajectory
        )

    def reference_points(self) -> FloatArray:
        return np.array([self.point], dtype=float)


class LineObject(ObjectSpec):
    """A straight line through ``point`` along ``direction``."""

    kind: Literal["line"]
    point: Vec3 = Field([0.0, 0.0, 0.0], description="a point of the line, object frame (m)")
    direction: Vec3 = Field([0.0, 1.0, 0.0], description="direction, object frame (non-zero)")

    @model_validator(mode="after")
    def _direction(self) -> LineObject:
        _nonzero(self.direction, "direction")
        return self

    def scene_object(self, trajectory: Trajectory) -> SceneObject:
        """The runtime :class:`~redservo.scene.Line`."""
        from redservo.scene import Line

        return Line(
            self.name, np.array(self.point), np.array(self.direction), trajectory=trajectory
        )

    def reference_points(self) -> FloatArray:
        return np.array([self.point], dtype=float)


OBJECT_KINDS: dict[str, type[ObjectSpec]] = {
    "points": PointsObject,
    "sphere": SphereObject,
    "cylinder": CylinderObject,
    "line": LineObject,
    "tag": TagObject,
}
"""Object kinds of ``[[objects]]``, by ``kind``: a new kind is one entry here."""
if TYPE_CHECKING:
    AnyObject = ObjectSpec
else:
    AnyObject = tagged_union(OBJECT_KINDS, default=None, what="object kind")
