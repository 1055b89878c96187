"""What the viewer and the animation show at each frame of a saved run (no graphics here).

A :class:`Playback` rebuilds the run's experiment from its resolved ``scenario.toml``
(:class:`redservo.runs.load.Run`) and gives, for a logged iteration ``k``, in the robot base
frame (m): the link frames (``robot.link_poses``), the joint axes with each joint's
closeness to its limits, the camera pose, the objects' geometry, and the image-plane
points (current and desired). Joint axes come from the base-frame Jacobian, so every
robot model gets them: for a revolute joint the angular column ``ω_j`` is the axis
direction and ``p_c + ω̂_j × v_j`` a point on it (``v_j`` the camera-origin velocity column);
a prismatic joint's direction is its linear column, drawn at the link it moves.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.features import object_adapter

if TYPE_CHECKING:  # pragma: no cover
    from redservo.experiment.build import Experiment
    from redservo.runs.load import Run
    from redservo.scene import Cylinder, Line, PointSet, Sphere

__all__ = [
    "LIMIT_COLORS",
    "Frame",
    "Playback",
    "cylinder_primitive",
    "limit_color",
    "limit_level",
    "line_primitive",
    "points_primitive",
    "sphere_primitive",
]

LIMIT_COLORS = ((0, 114, 178), (230, 159, 0), (213, 94, 0))
"""RGB of a joint far from its limits (blue), at its threshold (orange), at a limit
(vermillion): the Okabe-Ito colours, distinguishable with the common colour deficiencies."""


def limit_level(q_normalized: FloatArray, rho: float) -> FloatArray:
    """How close each joint is to a limit: 0 up to its threshold ``1 - 2 rho`` (normalized
    units, CM01 eq. 3), 1 at the limit, linear in between (dimensionless, clipped)."""
    edge = 1.0 - 2.0 * rho
    return np.clip((np.abs(q_normalized) - edge) / max(2.0 * rho, 1e-12), 0.0, 1.0)


def limit_color(level: float) -> tuple[int, int, int]:
    """RGB of a joint axis for a :func:`limit_level` (blue, then orange at 0+, red at 1)."""
    lo, mid, hi = (np.array(c, dtype=float) for c in LIMIT_COLORS)
    if level <= 0.0:
        c = lo
    else:
        c = mid + (hi - mid) * min(level, 1.0)
    return int(c[0]), int(c[1]), int(c[2])


@dataclass(frozen=True)
class Frame:
    """The scene at one logged iteration (base frame, m).

    Attributes:
        k: Iteration (0-based); t: time (s).
        links: Link frames ``{name: 4x4}``, base to tip.
        axes: Per joint ``(point (3,), unit direction (3,), prismatic?)``.
        levels: Per joint :func:`limit_level`.
        bMc: Camera pose (4x4).
        objects: Per object ``(name, kind, geometry)``: points (N, 3); a sphere's
            ``(centre (3,), radius)``; a cylinder's or line's segment (2, 3).
    """

    k: int
    t: float
    links: dict[str, FloatArray]
    axes: list[tuple[FloatArray, FloatArray, bool]]
    levels: FloatArray
    bMc: FloatArray
    objects: list[tuple[str, str, Any]]


class Playback:
    """A saved run, ready to be shown frame by frame.

    Args:
        run: The run (:func:`redservo.load_run`); it must hold its ``scenario.toml``.

    Raises:
        ConfigurationError: the run has no scenario, or its robot has no ``link_poses``.
    """

    def __init__(self, run: Run) -> None:
        self.run = run
        self.exp: Experiment = run.experiment()
        robot = self.exp.robot
        if not hasattr(robot, "link_poses"):
            raise ConfigurationError(
                f"robot {robot.name!r} has no link_poses(q): it cannot be shown", argument="robot"
            )
        self.q = np.asarray(run.arrays["q"])
        self.t = np.asarray(run.arrays["t"])
        self.qn = np.asarray(run.arrays["q_normalized"])
        self.s = np.asarray(run.arrays["s"])
        self.rho = float(self.exp.limits.rho)
        self.joint_names = tuple(robot.joint_names)

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def frames(self, max_frames: int = 200) -> list[int]:
        """Iterations to show: every ``stride``-th one and the last, at most ``max_frames``."""
        n = len(self)
        stride = max(1, int(np.ceil(n / max(1, max_frames - 1))))
        ks = list(range(0, n, stride))
        if ks[-1] != n - 1:
            ks.append(n - 1)
        return ks

    def frame(self, k: int) -> Frame:
        """The scene at iteration ``k`` (0-based)."""
        robot, q = self.exp.robot, self.q[k]
        links = robot.link_poses(q, check_limits=False)  # type: ignore[attr-defined]
        bMc = robot.fkine(q, check_limits=False)
        return Frame(
            k=k,
            t=float(self.t[k]),
            links=links,
            axes=self._axes(q, bMc, links),
            levels=limit_level(self.qn[k], self.rho),
            bMc=bMc,
            objects=self._objects(float(self.t[k])),
        )

    def _axes(
        self, q: FloatArray, bMc: FloatArray, links: dict[str, FloatArray]
    ) -> list[tuple[FloatArray, FloatArray, bool]]:
        robot = self.exp.robot
        J = robot.jacobian(q, check_limits=False)  # camera frame: v_c = J q̇
        R = bMc[:3, :3]
        v, w = R @ J[:3], R @ J[3:]
        origins = [T[:3, 3] for T in links.values()]
        out = []
        for j, kind in enumerate(robot.joint_types):
            if kind == "prismatic":
                d = v[:, j] / max(float(np.linalg.norm(v[:, j])), 1e-12)
                p = origins[min(j + 1, len(origins) - 1)]
                out.append((p, d, True))
                continue
            norm = float(np.linalg.norm(w[:, j]))
            d = w[:, j] / max(norm, 1e-12)
            p = bMc[:3, 3] + np.cross(d, v[:, j]) / max(norm, 1e-12)
            # Slide along the axis to the point nearest the chain (looks attached).
            near = min(origins, key=lambda o: float(np.linalg.norm(np.cross(o - p, d))))
            p = p + d * float(np.dot(near - p, d))
            out.append((p, d, False))
        return out

    @cached_property
    def _geometry(self) -> list[tuple[str, str, Any]]:
        """``(name, primitive, geometry)`` of the drawn objects: the ``viewer`` adapter their
        feature kind declares (:mod:`redservo.features.kinds`)."""
        out: list[tuple[str, str, Any]] = []
        scene = self.exp.scene
        for name in scene.names:
            obj = scene.object(name)
            adapter = object_adapter(obj, "viewer")
            if adapter is not None:
                out.append((name, *adapter(obj)))
        return out

    def _objects(self, t: float) -> list[tuple[str, str, Any]]:
        scene = self.exp.scene
        bMw = np.linalg.inv(scene.wMb)
        out: list[tuple[str, str, Any]] = []
        for name, kind, geo in self._geometry:
            bMo = bMw @ scene.wMo(name, t)
            R, p = bMo[:3, :3], bMo[:3, 3]
            if kind == "points":
                out.append((name, kind, geo @ R.T + p))
            elif kind == "sphere":
                out.append((name, kind, (R @ geo[0] + p, geo[1])))
            else:
                c, d, r = R @ geo[0] + p, R @ geo[1], geo[2]
                half = 0.25
                out.append((name, kind, (np.array([c - half * d, c + half * d]), r)))
        return out

    # -- image plane ------------------------------------------------------------------------

    @cached_property
    def point_slices(self) -> list[tuple[int, int]]:
        """(x, y) indices in ``s`` of every point feature."""
        from redservo.plots.figures import FigureContext

        return list(FigureContext.of(self.exp).point_slices)

    @cached_property
    def desired_xy(self) -> FloatArray:
        """(P, 2) desired image points (normalized) of the point features (``s*``)."""
        s_star = np.asarray(self.exp.task.s_star)
        return np.array([[s_star[i], s_star[j]] for i, j in self.point_slices]).reshape(-1, 2)

    def current_xy(self, k: int) -> FloatArray:
        """(P, 2) current image points (normalized) of the point features at iteration k."""
        s = self.s[k]
        return np.array([[s[i], s[j]] for i, j in self.point_slices]).reshape(-1, 2)

    def projected(self, k: int) -> list[tuple[str, FloatArray]]:
        """Every object's sample points seen by the camera at iteration k:
        ``(kind, (M, 2) normalized coordinates)``, points behind the camera left out."""
        cMb = np.asarray(
            np.linalg.inv(self.exp.robot.fkine(self.q[k], check_limits=False)), dtype=float
        )
        return self._project(cMb, float(self.t[k]))

    @cached_property
    def desired_projected(self) -> list[tuple[str, FloatArray]]:
        """The objects seen from the desired camera pose (``task.desired_pose``), or []."""
        spec = self.exp.scenario.spec
        if spec.task.desired_pose is None:
            return []
        scene = self.exp.scene
        ref = spec.features[0].object
        wMcd = scene.wMo(ref, 0.0) @ np.linalg.inv(spec.task.desired_pose.matrix())
        cdMb = np.linalg.inv(np.linalg.inv(scene.wMb) @ wMcd)
        return self._project(np.asarray(cdMb, dtype=float), 0.0)

    def _project(self, cMb: FloatArray, t: float) -> list[tuple[str, FloatArray]]:
        out = []
        for _, kind, geo in self._objects(t):
            if kind == "points":
                Pc = geo @ cMb[:3, :3].T + cMb[:3, 3]
            elif kind == "sphere":
                c, r = geo
                cc = cMb[:3, :3] @ c + cMb[:3, 3]
                # The limb seen from the camera: a circle normal to the viewing ray.
                z = cc / max(float(np.linalg.norm(cc)), 1e-12)
                u = np.cross(z, [0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0])
                u /= np.linalg.norm(u)
                w = np.cross(z, u)
                a = np.linspace(0, 2 * np.pi, 48, endpoint=False)
                Pc = cc + r * (np.outer(np.cos(a), u) + np.outer(np.sin(a), w))
            else:
                seg, _ = geo
                P = seg[0] + np.linspace(-4.0, 5.0, 90)[:, None] * (seg[1] - seg[0])
                Pc = P @ cMb[:3, :3].T + cMb[:3, 3]
            front = Pc[:, 2] > 1e-6
            out.append((kind, Pc[front, :2] / Pc[front, 2:3]))
        return out


def points_primitive(obj: PointSet) -> tuple[str, Any]:
    """A point set: its points (k, 3; m) (the point kind's ``viewer`` adapter)."""
    return "points", np.asarray(obj.points)


def sphere_primitive(obj: Sphere) -> tuple[str, Any]:
    """A sphere: ``(centre (3,), radius)`` (m) (the sphere kind's ``viewer`` adapter)."""
    return "sphere", (np.asarray(obj.center), float(obj.radius))


def cylinder_primitive(obj: Cylinder) -> tuple[str, Any]:
    """A cylinder: ``(point, axis, radius)`` (m) (the cylinder kind's ``viewer`` adapter)."""
    return "cylinder", (obj.point, obj.axis, float(obj.radius))


def line_primitive(obj: Line) -> tuple[str, Any]:
    """A line: ``(point, direction, 0)`` (m) (the line kind's ``viewer`` adapter)."""
    return "line", (obj.point, obj.direction, 0.0)
