"""Scene objects posed in the world frame, and how they move.

A :class:`Scene` holds named objects and the robot base pose ``wMb`` in the
world frame. Each object carries its geometry in its own frame ``o`` and a
:class:`Trajectory` giving ``wMo(t)``. With the camera pose ``bMc`` in the base
frame (``Robot.fkine(q)``), the object pose in the camera frame is
``cMo = inv(bMc) @ inv(wMb) @ wMo(t)``, the input of every
:class:`~redservo.features.base.Feature`. The geometry fields use the same
names as the feature constructors (``radius``, ``center``, ``axis``, ``point``,
``direction``, ``points``).

Velocity convention (decision): :meth:`Trajectory.twist` returns
``(ṗ, ω)`` where ``ṗ`` (m/s) is the velocity of the object-frame *origin* and
``ω`` (rad/s) the angular velocity, both expressed in the world frame. For the
feed-forward term of CM01 eq. 2, :meth:`Scene.object_twist` converts it to the
object's twist in the camera frame about the camera origin, ``v_o``; a feature
then moves as ``ṡ = L_s (v_c - v_o)``, so ``∂s/∂t = -L_s v_o``.

Decisions:
    * :class:`ConstantVelocity` is the exponential motion on R³ x SO(3): the
      origin moves on a straight line at constant ``v`` while the object spins
      at constant ``ω`` about its own origin, ``p(t) = p0 + v t``,
      ``R(t) = exp(t [ω]x) R0``. Then ``twist(t) = (v, ω)`` at every ``t``,
      which is what "constant velocity" means to a scenario author. (The SE(3)
      exponential would move the origin on a helix.)
    * :class:`Waypoints` interpolates the translation linearly and the rotation
      along the shortest geodesic (slerp), segment by segment; the pose is
      constant before the first and after the last waypoint. Its twist is
      piecewise constant and right-continuous (at a waypoint it is the velocity
      of the segment that starts there; zero from the last waypoint on).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_matrix, as_transform, as_vector
from redservo.errors import ConfigurationError, GeometryError, ShapeError, UnknownNameError
from redservo.spatial import inverse, matrix_to_rotvec, rotvec_to_matrix, twist_transform
from redservo.vision.tag_families import check_tag, tag_points

__all__ = [
    "ConstantVelocity",
    "Cylinder",
    "Line",
    "PointSet",
    "Scene",
    "SceneObject",
    "Sphere",
    "Static",
    "Tag",
    "Trajectory",
    "Waypoints",
]

_NO_BASE = np.zeros((0, 0))
"""``bMw`` of :meth:`Scene._pose_parts` when the base is at the world origin (no product)."""


def _time(t: float) -> float:
    value = float(t)
    if not np.isfinite(value):
        raise ConfigurationError(f"time t must be finite, got {t!r}")
    return value


# --------------------------------------------------------------------------- trajectories


class Trajectory(abc.ABC):
    """The pose of an object in the world frame as a function of time (s)."""

    @abc.abstractmethod
    def pose(self, t: float) -> FloatArray:
        """Return ``wMo`` (4x4) at time ``t`` (s)."""

    @abc.abstractmethod
    def twist(self, t: float) -> FloatArray:
        """Return ``(ṗ, ω)`` (6,): origin velocity (m/s) and angular velocity (rad/s), world frame."""


@dataclass(frozen=True, eq=False)
class Static(Trajectory):
    """An object that does not move.

    Attributes:
        wMo: 4x4 pose in the world frame (default identity).
    """

    wMo: FloatArray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        object.__setattr__(self, "wMo", as_transform(self.wMo, "wMo"))

    def pose(self, t: float) -> FloatArray:
        _time(t)
        return self.wMo.copy()

    def twist(self, t: float) -> FloatArray:
        _time(t)
        return np.zeros(6)


@dataclass(frozen=True, eq=False)
class ConstantVelocity(Trajectory):
    """Constant linear and angular velocity from ``wMo0`` at ``t = 0`` (see module docstring).

    ``p(t) = p0 + v t`` and ``R(t) = exp(t [w]x) R0``; valid for negative ``t`` too.

    Attributes:
        wMo0: 4x4 pose at ``t = 0``.
        v: (3,) velocity of the object origin, world frame (m/s).
        w: (3,) angular velocity, world frame (rad/s).
    """

    wMo0: FloatArray
    v: FloatArray
    w: FloatArray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        object.__setattr__(self, "wMo0", as_transform(self.wMo0, "wMo0"))
        object.__setattr__(self, "v", as_vector(self.v, "v", 3))
        object.__setattr__(self, "w", as_vector(self.w, "w", 3))

    def pose(self, t: float) -> FloatArray:
        tt = _time(t)
        T = np.eye(4)
        T[:3, :3] = rotvec_to_matrix(self.w * tt) @ self.wMo0[:3, :3]
        T[:3, 3] = self.wMo0[:3, 3] + self.v * tt
        return T

    def twist(self, t: float) -> FloatArray:
        _time(t)
        return np.concatenate([self.v, self.w])


@dataclass(frozen=True, eq=False)
class Waypoints(Trajectory):
    """Piecewise motion through timed poses (see module docstring).

    Attributes:
        times: (K,) strictly increasing times (s), K >= 1.
        poses: (K, 4, 4) poses ``wMo`` at those times.
    """

    times: FloatArray
    poses: FloatArray
    _rotvecs: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        times = as_vector(self.times, "times")
        poses = np.asarray(self.poses, dtype=float)
        if times.shape[0] == 0:
            raise ShapeError("Waypoints needs at least one waypoint, got times of length 0")
        if poses.shape != (times.shape[0], 4, 4):
            raise ShapeError(
                f"poses must have shape ({times.shape[0]}, 4, 4) to match times, got {poses.shape}"
            )
        if np.any(np.diff(times) <= 0.0):
            raise ConfigurationError(f"times must be strictly increasing, got {times}")
        poses = np.stack([as_transform(P, f"poses[{k}]") for k, P in enumerate(poses)])
        # World-frame rotation vector of each segment: R_{k+1} = exp([r_k]x) R_k.
        rv = np.array(
            [
                matrix_to_rotvec(poses[k + 1, :3, :3] @ poses[k, :3, :3].T)
                for k in range(len(times) - 1)
            ]
        )
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "poses", poses)
        object.__setattr__(self, "_rotvecs", rv.reshape(-1, 3))

    def _segment(self, t: float) -> int | None:
        """Index k of the segment [t_k, t_{k+1}) containing t, or None outside."""
        if t < self.times[0] or t >= self.times[-1]:
            return None
        return int(np.searchsorted(self.times, t, side="right")) - 1

    def pose(self, t: float) -> FloatArray:
        tt = _time(t)
        k = self._segment(tt)
        if k is None:
            return self.poses[0].copy() if tt < self.times[0] else self.poses[-1].copy()
        tau = (tt - self.times[k]) / (self.times[k + 1] - self.times[k])
        T = np.eye(4)
        T[:3, :3] = rotvec_to_matrix(tau * self._rotvecs[k]) @ self.poses[k, :3, :3]
        T[:3, 3] = (1.0 - tau) * self.poses[k, :3, 3] + tau * self.poses[k + 1, :3, 3]
        return T

    def twist(self, t: float) -> FloatArray:
        tt = _time(t)
        k = self._segment(tt)
        if k is None:
            return np.zeros(6)
        dt = self.times[k + 1] - self.times[k]
        v = (self.poses[k + 1, :3, 3] - self.poses[k, :3, 3]) / dt
        return np.concatenate([v, self._rotvecs[k] / dt])


# --------------------------------------------------------------------------- objects


def _unit(value: ArrayLike, name: str) -> FloatArray:
    vec = as_vector(value, name, 3)
    norm = float(np.linalg.norm(vec))
    if norm < 1e-12:
        raise GeometryError(f"zero-length axis: {name} must be a non-zero 3-vector, got {vec}")
    return vec / norm


def _radius(value: float) -> float:
    r = float(value)
    if not (np.isfinite(r) and r > 0.0):
        raise GeometryError(f"radius must be positive and finite (m), got {value!r}")
    return r


@dataclass(frozen=True, eq=False)
class SceneObject:
    """A named object; subclasses add their geometry, given in the object frame (m).

    Attributes:
        name: Unique name in the scene.
        trajectory: Its motion ``wMo(t)`` (keyword-only; default: static at the world origin).
    """

    name: str
    trajectory: Trajectory = field(default_factory=Static, kw_only=True)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ConfigurationError(f"object name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.trajectory, Trajectory):
            raise ConfigurationError(
                f"trajectory of {self.name!r} must be a Trajectory, got {type(self.trajectory).__name__}"
            )


@dataclass(frozen=True, eq=False)
class PointSet(SceneObject):
    """Points (N, 3) in the object frame (m), N >= 1 (e.g. the dots of a planar target)."""

    points: FloatArray

    def __post_init__(self) -> None:
        super().__post_init__()
        pts = np.asarray(self.points, dtype=float)
        if pts.ndim == 1:
            pts = pts.reshape(1, -1)
        pts = as_matrix(pts, "points", None, 3)
        if pts.shape[0] == 0:
            raise ShapeError("points must hold at least one point, got shape (0, 3)")
        object.__setattr__(self, "points", pts)


@dataclass(frozen=True, eq=False)
class Tag(PointSet):
    """A square fiducial tag (AprilTag or ArUco): ``size`` (m, the black square's side), ``tag_id``
    and ``family``; its ``points`` are its 4 corners in ViSP's tag frame
    (:func:`redservo.vision.tag_families.tag_points`; docs/vision.md, Tags)."""

    points: FloatArray = field(init=False)
    size: float = 0.05
    tag_id: int = 0
    family: str = "36h11"

    def __post_init__(self) -> None:
        object.__setattr__(self, "family", check_tag(self.family, self.tag_id))
        object.__setattr__(self, "points", tag_points(self.size))
        object.__setattr__(self, "size", float(self.size))
        super().__post_init__()


@dataclass(frozen=True, eq=False)
class Sphere(SceneObject):
    """A sphere of ``radius`` (m) centred at ``center`` (3,) in the object frame."""

    radius: float
    center: FloatArray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "radius", _radius(self.radius))
        object.__setattr__(self, "center", as_vector(self.center, "center", 3))


@dataclass(frozen=True, eq=False)
class Cylinder(SceneObject):
    """An infinite cylinder of ``radius`` (m) around the line through ``point`` along ``axis``.

    ``axis`` is stored normalized; a zero-length axis raises :class:`GeometryError`.
    """

    radius: float
    axis: FloatArray
    point: FloatArray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "radius", _radius(self.radius))
        object.__setattr__(self, "axis", _unit(self.axis, "axis"))
        object.__setattr__(self, "point", as_vector(self.point, "point", 3))


@dataclass(frozen=True, eq=False)
class Line(SceneObject):
    """A straight line through ``point`` along ``direction`` (stored normalized), object frame."""

    point: FloatArray
    direction: FloatArray

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "point", as_vector(self.point, "point", 3))
        object.__setattr__(self, "direction", _unit(self.direction, "direction"))


# --------------------------------------------------------------------------- scene


class Scene:
    """Named objects in the world, and the robot base pose ``wMb``.

    Args:
        objects: The objects; names must be unique.
        wMb: 4x4 pose of the robot base in the world frame (default identity).
    """

    def __init__(
        self, objects: Iterable[SceneObject] = (), *, wMb: ArrayLike | None = None
    ) -> None:
        self._objects: dict[str, SceneObject] = {}
        for obj in objects:
            if not isinstance(obj, SceneObject):
                raise ConfigurationError(
                    f"scene objects must be SceneObject, got {type(obj).__name__}"
                )
            if obj.name in self._objects:
                raise ConfigurationError(f"duplicate object name {obj.name!r} in the scene")
            self._objects[obj.name] = obj
        self.wMb: FloatArray = as_transform(np.eye(4) if wMb is None else wMb, "wMb")
        self._bMw = inverse(self.wMb)
        # With the base at the world origin, ``cMb @ bMw`` is ``cMb`` (to the sign of a zero,
        # which never reaches the product with ``wMo``): that product is skipped.
        self._base_at_origin = bool(np.array_equal(self._bMw, np.eye(4)))

    @property
    def names(self) -> tuple[str, ...]:
        """Object names, in insertion order."""
        return tuple(self._objects)

    def object(self, name: str) -> SceneObject:
        """Return the object called ``name``; :class:`UnknownNameError` lists the known names."""
        try:
            return self._objects[name]
        except KeyError:
            known = ", ".join(repr(n) for n in self._objects) or "(none)"
            raise UnknownNameError(
                f"unknown scene object {name!r}; known objects: {known}"
            ) from None

    def wMo(self, name: str, t: float = 0.0) -> FloatArray:
        """Pose (4x4) of object ``name`` in the world frame at time ``t`` (s)."""
        return self.object(name).trajectory.pose(t)

    def cMo(self, name: str, bMc: ArrayLike, t: float = 0.0) -> FloatArray:
        """Pose (4x4) of object ``name`` in the camera frame, for the camera pose ``bMc`` (4x4)."""
        T, bMw, wMo = self._pose_parts(name, bMc, t)
        cMw = inverse(T)
        if bMw.shape[0] != 0:
            cMw = cMw @ bMw
        return cMw @ wMo  # wMo read, not copied: the product is the fresh array

    def _pose_parts(
        self, name: str, bMc: ArrayLike, t: float = 0.0
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The factors of :meth:`cMo`, ``cMo = inverse(bMc) · bMw · wMo``: ``(bMc, bMw, wMo)``
        (4x4 each; ``bMc`` validated, ``bMw`` a (0, 0) array when the base is at the world
        origin and the product is skipped, ``wMo`` the object's pose at ``t`` (s), read, not
        copied: do not write into it). What a compiled caller multiplies itself
        (:func:`redservo.kernels.points_task.points_task`, with the same operations).

        Raises:
            ShapeError: ``bMc`` is not a homogeneous transform.
            UnknownNameError: no object ``name``.
            ConfigurationError: ``t`` is not a finite number.
        """
        T = as_transform(bMc, "bMc")
        return (T, *self._target_pose(name, t))

    def _target_pose(self, name: str, t: float) -> tuple[FloatArray, FloatArray]:
        """``(bMw, wMo)`` of :meth:`_pose_parts`, for a caller that checks ``bMc`` itself.

        Raises:
            UnknownNameError: no object ``name``.
            ConfigurationError: ``t`` is not a finite number.
        """
        obj = self._objects.get(name)
        traj = (self.object(name) if obj is None else obj).trajectory
        if type(traj) is Static:
            if type(t) is not float or not math.isfinite(t):
                _time(t)  # what Static.pose checks (an int is fine, NaN and inf raise)
            wMo = traj.wMo
        else:
            wMo = traj.pose(t)
        return (_NO_BASE if self._base_at_origin else self._bMw), wMo

    def _cMw(self, bMc: ArrayLike) -> FloatArray:
        """``cMw = inv(bMc) @ bMw`` for a camera pose ``bMc`` given by the caller (validated)."""
        cMb = inverse(as_transform(bMc, "bMc"))
        return cMb if self._base_at_origin else cMb @ self._bMw

    def object_twist(self, name: str, bMc: ArrayLike, t: float = 0.0) -> FloatArray:
        """Twist (6,) of object ``name`` in the camera frame, about the camera origin.

        ``v_o = (v, ω)``: a point ``X`` (camera frame) of the object moves as
        ``Ẋ = v + ω x X`` while the camera holds still, so a feature's own
        variation is ``∂s/∂t = -L_s v_o`` (units m/s and rad/s).
        """
        twist_w = self.object(name).trajectory.twist(t)
        p = self.wMo(name, t)[:3, 3]
        # Spatial twist about the world origin, then moved to the camera frame.
        v_s = twist_w[:3] - np.cross(twist_w[3:], p)
        cMw = self._cMw(bMc)
        return np.asarray(twist_transform(cMw) @ np.concatenate([v_s, twist_w[3:]]), dtype=float)
