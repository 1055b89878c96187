"""Composable secondary objectives: joint-space commands added to the law's ``secondary``.

The :class:`~redservo.control.Controller` sums the commands of every objective and passes the
sum as the law's ``secondary`` input; the law projects it with its own operator (``J1^⊥`` for
the CM01 family, the directional projector for MC05). An objective may also end the run (the
occlusion objective reports ``occluded``): the first one that does wins and no command is
computed. This is how mink composes tasks and limits: nothing objective-specific lives in a
loop.

* :class:`OcclusionAvoidance` — MC05 eqs. 30-31: the artificial force pushing the image of
  a target away from the image of an occluding sphere.
* :class:`JointLimitForce` — MC05 eqs. 27-29: the joint-limit repulsion.
* :class:`CallableObjective` — any user function ``f(state, q, t) -> (n,) or None``.

**What an objective may rely on.** Every loop gives ``J``, ``q``, ``limits``, ``state``, ``t``
and ``robot`` in the :class:`ObjectiveContext`. Only the simulator knows the scene and the
true camera pose: in the servo loop of a real arm (:class:`~redservo.hardware.ServoLoop`)
``ctx.scene`` and ``ctx.bMc`` are None. An objective that needs the scene there must be given
it (``OcclusionAvoidance(occlusion, scene=...)``, which then uses the model robot's
``fkine(q)`` as the camera pose); one that still lacks it says so with ``needs_scene = True``
and the servo loop refuses it when it is built. An objective with a ``reset()`` method is
reset at the start of every run.

Units: seconds, metres, radians; commands in rad/s or m/s per joint.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.features.point import point_interaction
from redservo.limits import JointLimits
from redservo.redundancy.costs import joint_limit_force, occlusion_force
from redservo.robots.base import Robot
from redservo.scene import Scene, Sphere
from redservo.task import TaskState

__all__ = [
    "CallableObjective",
    "JointLimitForce",
    "Objective",
    "ObjectiveContext",
    "Occlusion",
    "OcclusionAvoidance",
    "occlusion_state",
    "visible_points",
]


class ObjectiveContext(NamedTuple):
    """What an objective may read at one step (see the module docstring)."""

    scene: Scene | None
    """The scene (simulator only; None in the servo loop of a real arm)."""
    bMc: FloatArray | None
    """4x4 true camera pose in the base frame (simulator only; None in the servo loop)."""
    J: FloatArray
    """(6, n) robot Jacobian the controller uses (its model, ``cVe eJe(q)``)."""
    q: FloatArray
    """(n,) measured joint positions (m or rad)."""
    limits: JointLimits
    state: TaskState
    """The task at this step (``e1``, ``J1``, ``s``, ...)."""
    t: float
    """Time of the measurement (s) since the start of the run."""
    robot: Robot | None = None
    """The controller's model robot (its ``eMc`` is the hand-eye calibration)."""


class Objective(Protocol):
    """A secondary objective: ``__call__`` returns ``(command (n,) or None, outcome or None)``.

    The command is in rad/s or m/s per joint; an outcome (e.g. ``"occluded"``) ends the run.
    """

    def __call__(self, ctx: ObjectiveContext) -> tuple[FloatArray | None, str | None]: ...


@dataclass
class CallableObjective:
    """Wrap a user function ``f(state, q, t) -> (n,) joint command or None``."""

    function: Callable[[TaskState, FloatArray, float], FloatArray | None]

    def __call__(self, ctx: ObjectiveContext) -> tuple[FloatArray | None, str | None]:
        return self.function(ctx.state, ctx.q, ctx.t), None


@dataclass
class JointLimitForce:
    """MC05's joint-limit force (eqs. 27-29) as an objective, scaled by ``kappa``."""

    kappa: float = 1.0

    def __call__(self, ctx: ObjectiveContext) -> tuple[FloatArray | None, str | None]:
        return joint_limit_force(ctx.q, ctx.limits, kappa=self.kappa), None


@dataclass(frozen=True, kw_only=True)
class Occlusion:
    """An occluding sphere that may hide a point-set target (MC05 experiment 2).

    The occluder's image is approximated by the disc of centre ``X0/Z0`` and
    radius ``r / sqrt(Z0² - r²)`` (normalized units). The target is *occluded*
    when one of its points falls inside that disc while the occluder is nearer
    the camera. With ``avoid=True`` the MC05 occlusion force (eq. 31), computed
    from the occluder's image point closest to the nearest target point, is
    passed to the law as its ``secondary`` command, scaled by ``gain``
    (:class:`OcclusionAvoidance`).

    Attributes:
        occluder: Scene name of the occluding :class:`~redservo.scene.Sphere`.
        target: Scene name of the observed :class:`~redservo.scene.PointSet`.
        beta: ``β`` of the cost ``V = exp(-β d²)`` (MC05 eq. 30), 1/(normalized units)².
        gain: Scale of the artificial force (joint velocity per unit force).
        avoid: Feed the force to the law as ``secondary``.
    """

    occluder: str
    target: str
    beta: float = 50.0
    gain: float = 1.0
    avoid: bool = True


def visible_points(scene: Scene, name: str, bMc: FloatArray, t: float) -> FloatArray:
    """Camera-frame points whose image must stay in view for object ``name`` (N, 3), m."""
    obj = scene.object(name)
    cMo = scene.cMo(name, bMc, t)
    if hasattr(obj, "points"):  # a point set, a tag or any object of points
        pts = np.asarray(obj.points, dtype=float)
    elif hasattr(obj, "center"):
        pts = np.asarray(obj.center, dtype=float)[None, :]
    elif hasattr(obj, "point"):
        pts = np.asarray(obj.point, dtype=float)[None, :]
    else:  # pragma: no cover - every scene object has a reference point
        pts = np.zeros((1, 3))
    return np.asarray(pts @ cMo[:3, :3].T + cMo[:3, 3])


def occlusion_state(
    scene: Scene, occ: Occlusion, bMc: FloatArray, t: float
) -> tuple[bool, FloatArray | None, FloatArray | None, float]:
    """Return (occluded, occluder image point p_a, nearest target point, occluder depth (m)).

    The occluder's image is the disc of centre ``X0/Z0`` and radius ``r / sqrt(Z0² - r²)``.
    """
    sph = scene.object(occ.occluder)
    if not isinstance(sph, Sphere):
        raise ConfigurationError(f"occluder {occ.occluder!r} must be a Sphere")
    cMo = scene.cMo(occ.occluder, bMc, t)
    X0 = cMo[:3, :3] @ np.asarray(sph.center, dtype=float) + cMo[:3, 3]
    r = float(sph.radius)
    if X0[2] <= r:  # behind or around the camera plane: cannot occlude
        return False, None, None, 0.0
    c = X0[:2] / X0[2]
    radius = r / np.sqrt(X0[2] ** 2 - r**2)
    P = visible_points(scene, occ.target, bMc, t)
    xy = P[:, :2] / P[:, 2:3]
    dist = np.linalg.norm(xy - c, axis=1)
    j = int(np.argmin(dist))
    occluded = bool(np.any((dist < radius) & (P[:, 2] > X0[2] - r)))
    direction = xy[j] - c
    nd = float(np.linalg.norm(direction))
    p_a = c + (radius * direction / nd if nd > 1e-12 else np.array([radius, 0.0]))
    return occluded, p_a, xy[j], float(X0[2])


@dataclass
class OcclusionAvoidance:
    """MC05's occlusion avoidance (eqs. 30-31): stop when occluded, else push away.

    The force is computed from the occluder's image point closest to the nearest target
    point, with the interaction matrix of that image point at the occluder's depth.

    Args:
        occlusion: The occluder, the target and the force's parameters.
        scene: The scene to use when the loop gives none (the servo loop of a real arm: the
            objects' poses must then be known, and the camera pose is the model robot's
            ``fkine(q)``). None: the loop's scene (the simulator's).
    """

    occlusion: Occlusion
    scene: Scene | None = None

    @property
    def needs_scene(self) -> bool:
        """True when this objective has no scene of its own (it then needs the loop's)."""
        return self.scene is None

    def __call__(self, ctx: ObjectiveContext) -> tuple[FloatArray | None, str | None]:
        occ = self.occlusion
        scene, bMc = ctx.scene, ctx.bMc
        if scene is None or bMc is None:
            if self.scene is None or ctx.robot is None:
                raise ConfigurationError(
                    "OcclusionAvoidance needs the scene (the occluder's and the target's "
                    "poses), which this loop does not have: build it with "
                    "OcclusionAvoidance(occlusion, scene=...)",
                    argument="objectives",
                )
            scene, bMc = self.scene, ctx.robot.fkine(ctx.q, check_limits=False)
        occluded, p_a, p_t, z_occ = occlusion_state(scene, occ, bMc, ctx.t)
        if occluded:
            return None, "occluded"
        if not occ.avoid or p_a is None or p_t is None:
            return None, None
        H = point_interaction(float(p_a[0]), float(p_a[1]), 1.0 / z_occ) @ ctx.J
        f = occlusion_force(p_a, p_t, H, beta=occ.beta).force
        return occ.gain * f, None
