"""Composable secondary objectives: joint-space commands added to the law's ``secondary``.

The simulator (and the servo loop) sums the commands of every objective and passes the
sum as the law's ``secondary`` input; the law projects it with its own operator
(``J1^⊥`` for the CM01 family, the directional projector for MC05). An objective may
also end the run (the occlusion objective reports ``occluded``). This is how mink
composes tasks and limits: nothing objective-specific lives in the simulator.

* :class:`OcclusionAvoidance` — MC05 eqs. 30-31: the artificial force pushing the image of
  a target away from the image of an occluding sphere.
* :class:`JointLimitForce` — MC05 eqs. 27-29: the joint-limit repulsion.
* :class:`CallableObjective` — any user function ``f(state, q, t) -> (n,) or None``.
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
from redservo.scene import PointSet, Scene, Sphere
from redservo.simulation.options import Occlusion
from redservo.task import TaskState

__all__ = [
    "CallableObjective",
    "JointLimitForce",
    "Objective",
    "ObjectiveContext",
    "OcclusionAvoidance",
    "visible_points",
]


class ObjectiveContext(NamedTuple):
    """What an objective may read at one iteration."""

    scene: Scene
    bMc: FloatArray
    """4x4 true camera pose."""
    J: FloatArray
    """(6, n) robot Jacobian the controller uses."""
    q: FloatArray
    limits: JointLimits
    state: TaskState
    t: float


class Objective(Protocol):
    """A secondary objective: ``__call__`` returns ``(command (n,) or None, outcome or None)``."""

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


def visible_points(scene: Scene, name: str, bMc: FloatArray, t: float) -> FloatArray:
    """Camera-frame points whose image must stay in view for object ``name`` (N, 3)."""
    obj = scene.object(name)
    cMo = scene.cMo(name, bMc, t)
    if isinstance(obj, PointSet):
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
    """Return (occluded, occluder image point p_a, nearest target point, occluder depth).

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
    """

    occlusion: Occlusion

    def __call__(self, ctx: ObjectiveContext) -> tuple[FloatArray | None, str | None]:
        occ = self.occlusion
        occluded, p_a, p_t, z_occ = occlusion_state(ctx.scene, occ, ctx.bMc, ctx.t)
        if occluded:
            return None, "occluded"
        if not occ.avoid or p_a is None or p_t is None:
            return None, None
        H = point_interaction(float(p_a[0]), float(p_a[1]), 1.0 / z_occ) @ ctx.J
        f = occlusion_force(p_a, p_t, H, beta=occ.beta).force
        return occ.gain * f, None
