"""Collision avoidance: a repulsive secondary objective and the distance shield (issue 30).

A :class:`Collision` is the set-up: the obstacles (:class:`~redservo.collision.Obstacle`,
world = base frame), whether the self pairs count, the security distance ``d_s``
(``d_safe``, m: never closer) and the influence distance ``d_i`` (``d_influence``, m: where
avoidance starts). Its :meth:`Collision.measure` gives every pair's signed distance ``d``
(m) and Jacobian ``J_d`` (m/rad or m/m, ``ḋ = J_d q̇ + ∂d/∂t``) from
:func:`redservo.collision.distances` (coal), the last answer cached (the objective, the
shield and the simulator's collision check ask at the same ``q`` and ``t``).

Two parts use it, one per level of the control scheme:

* :class:`CollisionAvoidance`, an objective (:mod:`redservo.control.objectives`): an
  **artificial repulsive joint velocity** fed to the law's ``secondary`` and projected by
  the law's own operator, as MC05's artificial forces for joint limits and occlusions are
  (Mansard & Chaumette 2005, §IV). For each pair closer than ``d_i`` it asks for the
  separating speed of a velocity damper (Faverjon & Tournassoud 1987: the approach speed
  allowed falls linearly to zero between ``d_i`` and ``d_s``; here the same ramp sets how
  fast to move away), ``v_k = ξ (d_i − d_k)/(d_i − d_s)`` (m/s, ``ξ`` at ``d_s``), and
  realises it with the damped minimum-norm joint velocity of that one distance::

      q̇_rep = Σ_k  J_kᵀ v_k / (‖J_k‖² + μ²)          (rad/s or m/s)

  (:func:`repulsive_command`; ``μ``, m/rad, keeps a pair near the base, whose ``J_k``
  vanishes, from asking for huge speeds).
* :func:`distance_shield`, the hard guarantee the :class:`~redservo.control.Controller`
  applies after the law's safety layer: the whole command is scaled so that no pair's
  first-order predicted distance falls below ``d_s`` within one period (module
  :func:`distance_shield`'s docstring gives the equation), flagged
  ``distance-shield-acted``.

Units: metres, seconds, radians.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.collision.pack import CompiledGeometry, compiled_geometry
from redservo.collision.query import distances
from redservo.collision.robot import LinkCapsule, link_capsules
from redservo.collision.shapes import Obstacle
from redservo.collision.urdf_query import is_urdf, urdf_elements
from redservo.control.objectives import ObjectiveContext
from redservo.errors import ConfigurationError
from redservo.redundancy.base import Diagnostics
from redservo.redundancy.distance_rows import bind_distances
from redservo.redundancy.flags import Event, Flag
from redservo.robots.base import Robot
from redservo.scene import Static

__all__ = [
    "Collision",
    "CollisionAvoidance",
    "PairDistances",
    "check_collision",
    "collision_arm",
    "distance_shield",
    "exact_scale",
    "repulsive_command",
    "shield_command",
]

_DRIFT_STEP = 1e-3
"""Time step (s) of the finite difference that gives a moving obstacle's ``∂d/∂t``."""


class PairDistances(NamedTuple):
    """Every pair at one ``(q, t)``: ``P`` pairs, ``n`` joints."""

    d: FloatArray
    """(P,) signed distances (m, negative: overlap)."""
    J: FloatArray
    """(P, n) distance Jacobians ``∂d/∂q`` (m/rad or m/m)."""
    drift: FloatArray
    """(P,) ``∂d/∂t`` (m/s) from the obstacles' own motion (0 for static ones and self pairs)."""
    names: tuple[str, ...]
    """(P,) the pairs as ``"link/obstacle"`` or ``"link/link"``."""
    kinds: tuple[str, ...] = ()
    """(P,) each pair's kind, ``"environment"`` or ``"self"``."""

    def closest(self) -> tuple[float, str]:
        """The smallest distance (m) and its pair (``(inf, "")`` without pairs)."""
        if not self.names:
            return float("inf"), ""
        k = int(np.argmin(self.d))
        return float(self.d[k]), self.names[k]


def collision_arm(robot: Robot) -> Robot:
    """The arm whose links collide: ``robot``, or the arm carrying the target of an
    eye-to-hand set-up (its ``carrier``)."""
    return getattr(robot, "carrier", robot)


@dataclass(eq=False)
class Collision:
    """Collision set-up of a run (module docstring). Distances in m, ``xi`` in m/s.

    Attributes:
        obstacles: The obstacles (world = base frame).
        d_safe: ``d_s`` (m, >= 0): the shield keeps every pair at least this far apart.
        d_influence: ``d_i`` (m, > ``d_safe``): the repulsion acts on pairs closer than this.
        self_collision: Also the robot's self pairs (:func:`redservo.collision.self_pairs`).
        xi: ``ξ`` (m/s, > 0): separating speed the repulsion asks for at ``d_s``.
        damping: ``μ`` (m/rad, > 0) of the repulsion's damped inverse.
        enabled: False: only measured (the simulator's ``collision`` outcome and log
            columns), neither avoided nor shielded.
        avoid: Avoid: the repulsive objective (:class:`CollisionAvoidance`) and the
            velocity-damper rows of ``qp``, ``sns`` and ``predictive``
            (:mod:`redservo.redundancy.distance_rows`).
        repel: With ``avoid``, the repulsive objective acts (False: the rows alone).
        shield: The distance shield (:func:`distance_shield`) in the controller.
        capsules: The robot's capsules (default :func:`~redservo.collision.link_capsules`).
        srdf: A URDF robot's SRDF file: its ``<disable_collisions>`` pairs are not self
            pairs (:func:`~redservo.collision.urdf_pairs.urdf_self_pairs`).

    Raises:
        ConfigurationError: a value out of range (``argument`` names it).
    """

    obstacles: tuple[Obstacle, ...] = ()
    d_safe: float = 0.02
    d_influence: float = 0.10
    self_collision: bool = False
    xi: float = 0.05
    damping: float = 0.05
    enabled: bool = True
    avoid: bool = True
    repel: bool = True
    shield: bool = True
    capsules: tuple[LinkCapsule, ...] | None = None
    srdf: str | None = None
    _last: tuple[Any, PairDistances] | None = field(default=None, init=False, repr=False)
    _geometry: tuple[int, CompiledGeometry | None] | None = field(
        default=None, init=False, repr=False
    )

    def __post_init__(self) -> None:
        self.obstacles = tuple(self.obstacles)
        for ob in self.obstacles:
            if not isinstance(ob, Obstacle):
                raise ConfigurationError(
                    f"obstacles must be redservo.collision.Obstacle, got {ob!r:.60}",
                    argument="obstacles",
                )
        safe_ok = _real(self.d_safe) and self.d_safe >= 0.0
        checks = (
            ("d_safe", safe_ok, ">= 0 (m)"),
            (
                "d_influence",
                safe_ok and _real(self.d_influence) and self.d_influence > self.d_safe,
                f"> d_safe = {self.d_safe!r} (m)",
            ),
            ("xi", _real(self.xi) and self.xi > 0.0, "> 0 (m/s)"),
            ("damping", _real(self.damping) and self.damping > 0.0, "> 0 (m/rad)"),
        )
        for name, ok, allowed in checks:
            if not ok:
                raise ConfigurationError(
                    f"{name} must be a finite number {allowed}, got {getattr(self, name)!r}",
                    argument=name,
                )

    @property
    def last_time(self) -> float:
        """The time (s) of the last :meth:`measure` (0 before the first)."""
        return 0.0 if self._last is None else float(self._last[0][2])

    @property
    def active(self) -> bool:
        """Whether there is anything to measure (an obstacle or the self pairs)."""
        return bool(self.obstacles) or self.self_collision

    def check_robot(self, robot: Robot) -> None:
        """Raise a :class:`ConfigurationError` (``argument="collision"``) if ``robot`` has no
        collision model."""
        arm = collision_arm(robot)
        urdf = is_urdf(arm) and self.capsules is None
        if self.srdf is not None and not urdf:
            raise ConfigurationError(
                f"srdf: an SRDF names the self pairs of a URDF robot; {arm.name!r} is not one "
                "(its own pairs are redservo.collision.self_pairs')",
                argument="srdf",
            )
        try:
            urdf_elements(arm) if urdf else link_capsules(arm)
        except ConfigurationError as exc:
            raise ConfigurationError(str(exc), argument="collision") from None

    def compiled(self, robot: Robot) -> CompiledGeometry | None:
        """The compiled geometry of ``robot``'s arm among the obstacles
        (:mod:`redservo.collision.pack`), None when coal measures it."""
        arm = collision_arm(robot)
        if self._geometry is None or self._geometry[0] != id(arm):
            geo = compiled_geometry(arm, self.obstacles, self.self_collision, self.capsules)
            self._geometry = (id(arm), geo)
        return self._geometry[1]

    def measure(self, robot: Robot, q: FloatArray, t: float) -> PairDistances:
        """Every pair's distance and Jacobian at ``q`` (rad or m) and time ``t`` (s): the
        compiled kernels (:mod:`redservo.kernels.loop_collide`) when they cover the set-up,
        else coal (:func:`redservo.collision.distances`)."""
        arm = collision_arm(robot)
        qa = np.asarray(q, dtype=float)
        key = (id(arm), qa.tobytes(), float(t))
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        geo = self.compiled(robot)
        if geo is not None:
            d, J = geo.measure(qa)
            out = PairDistances(d, J, np.zeros(d.shape[0]), geo.names, geo.kinds)
            self._last = (key, out)
            return out
        recs = distances(
            arm,
            qa,
            self.obstacles,
            t=t,
            self_collision=self.self_collision,
            capsules=self.capsules,
            srdf=self.srdf,
        )
        by_name = {ob.name: ob for ob in self.obstacles}
        drift = np.zeros(len(recs))
        for k, rec in enumerate(recs):
            ob = by_name.get(rec.second) if rec.kind == "environment" else None
            if ob is not None and not isinstance(ob.trajectory, Static):
                M0, M1 = ob.pose(t), ob.pose(t + _DRIFT_STEP)
                b1 = M1[:3, :3] @ (M0[:3, :3].T @ (rec.b - M0[:3, 3])) + M1[:3, 3]
                drift[k] = -float(rec.normal @ (b1 - rec.b)) / _DRIFT_STEP
        out = PairDistances(
            np.array([r.distance for r in recs], dtype=float),
            np.array([r.jacobian for r in recs], dtype=float).reshape(len(recs), arm.n),
            drift,
            tuple(f"{r.first}/{r.second}" for r in recs),
            tuple(r.kind for r in recs),
        )
        self._last = (key, out)
        return out

    def probe(self, robot: Robot, q: FloatArray, t: float) -> PairDistances:
        """:meth:`measure` at ``(q, t)`` leaving the cache (and :attr:`last_time`) as they
        were: for a plan's predicted configurations, which the step's own measurement (the
        objective, the rows, the shield, the records) must not lose."""
        saved = self._last
        try:
            return self.measure(robot, q, t)
        finally:
            self._last = saved


def check_collision(collision: object, robot: Robot, law: object = None) -> Collision | None:
    """``collision`` checked for a controller of ``robot``: None or a :class:`Collision`
    whose robot has a collision model (else a ``ConfigurationError``, ``argument="collision"``).
    A ``law`` with velocity-damper rows (``qp``, ``sns``, ``predictive``) gets the set-up
    (:func:`redservo.redundancy.distance_rows.bind_distances`)."""
    if collision is None:
        bind_distances(law, None, robot)
        return None
    if not isinstance(collision, Collision):
        raise ConfigurationError(
            f"collision must be a redservo.control.avoidance.Collision or None, got "
            f"{collision!r:.60}",
            argument="collision",
        )
    if collision.active:
        collision.check_robot(robot)
    bind_distances(law, collision, robot)
    return collision


def _real(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value)


def repulsive_command(
    d: FloatArray,
    J: FloatArray,
    *,
    d_safe: float,
    d_influence: float,
    xi: float,
    damping: float,
) -> FloatArray:
    """The artificial repulsive joint velocity (n,) of the module docstring (rad/s or m/s).

    Args:
        d: (P,) signed distances (m).
        J: (P, n) their Jacobians (m/rad or m/m).
        d_safe, d_influence: ``d_s < d_i`` (m).
        xi: Separating speed at ``d_s`` (m/s).
        damping: ``μ`` (m/rad) of the damped inverse ``J_kᵀ / (‖J_k‖² + μ²)``.
    """
    from redservo.kernels.loop_collide import repulsive

    d, J = np.ascontiguousarray(d, dtype=float), np.ascontiguousarray(J, dtype=float)
    return np.asarray(repulsive(d, J, d_safe, d_influence, xi, damping))


def distance_shield(
    qdot: FloatArray,
    d: FloatArray,
    J: FloatArray,
    *,
    dt: float,
    d_safe: float,
    drift: FloatArray | None = None,
) -> tuple[float, int]:
    """The scale ``s ∈ [0, 1]`` of the command ``q̇`` that keeps every pair at ``d_s``.

    With the first-order prediction of each pair's distance one period ahead,
    ``d_k⁺(s) = d_k + dt (∂d_k/∂t + s J_k q̇)`` (m), ``s`` is the largest value in
    ``[0, 1]`` such that, for every pair ``k``:

    * ``d_k⁺(s) ≥ d_s`` when the pair is clear even with the robot at rest
      (``d_k + dt ∂d_k/∂t ≥ d_s``);
    * ``s J_k q̇ ≥ 0`` otherwise (inside ``d_s`` already, or pushed in by a moving
      obstacle): the command may only move the pair apart, never closer.

    Scaling the whole command keeps its direction, its velocity limits and, since 0 is in
    the safe range, its position limits; it may break ``q̈_max`` (the caller reports it).

    Args:
        qdot: (n,) the command (rad/s or m/s).
        d: (P,) the pairs' distances (m).
        J: (P, n) their Jacobians (m/rad or m/m).
        dt: Control period (s), > 0.
        d_safe: ``d_s`` (m).
        drift: (P,) ``∂d/∂t`` from the obstacles' motion (m/s); None: static.

    Returns:
        ``(s, k)``: the scale and the pair that bounds it (-1 when ``s = 1``).
    """
    from redservo.kernels.loop_collide import shield_scale

    d, J = np.ascontiguousarray(d, dtype=float), np.ascontiguousarray(J, dtype=float)
    dr = np.zeros(d.shape[0]) if drift is None else np.ascontiguousarray(drift, dtype=float)
    s, k = shield_scale(np.ascontiguousarray(qdot, dtype=float), d, J, dr, dt, d_safe)
    return float(s), int(k)


def shield_command(
    c: Collision | None,
    robot: Robot,
    qdot: FloatArray,
    diag: Diagnostics,
    q: FloatArray,
    t: float,
    dt: float,
    qdot_prev: FloatArray | None,
    qddot_max: FloatArray | None,
) -> tuple[FloatArray, Diagnostics]:
    """:func:`distance_shield` on ``qdot`` (rad/s or m/s) at ``(q, t)`` with the period
    ``dt`` (s), unless ``c`` is None or off: the command, scaled when it must be, and
    ``diag`` with the events to report: ``distance-shield-acted`` (its value the scale) and,
    when the scaling breaks ``q̈_max dt`` against ``qdot_prev``, ``acceleration-exceeded``
    (the distance outranks the acceleration limit, as the position limits do)."""
    if c is None or not (c.enabled and c.shield and c.active):
        return qdot, diag
    pd = c.measure(robot, q, t)
    s, k = distance_shield(qdot, pd.d, pd.J, dt=dt, d_safe=c.d_safe, drift=pd.drift)
    s, k = exact_scale(c, robot, q, t, dt, qdot, pd, s, k)
    if k < 0:
        return qdot, diag
    cmd = qdot * s
    what = f"pair {pd.names[k]} at {pd.d[k] * 1000:.1f} mm would pass d_safe = {c.d_safe * 1000:.1f} mm"
    events = [Event(Flag.DISTANCE_SHIELD, s, f"command scaled by {s:.3g}: {what}")]
    if qdot_prev is not None and qddot_max is not None:
        excess = np.abs(cmd - qdot_prev) / dt - qddot_max
        if np.any(excess > 1e-9 * qddot_max):
            why = "the distance shield outranked the acceleration limit"
            events.append(Event(Flag.ACCELERATION_EXCEEDED, float(np.max(excess)), why))
    return cmd, dataclasses.replace(diag, events=(*diag.events, *events))


def exact_scale(
    c: Collision,
    robot: Robot,
    q: FloatArray,
    t: float,
    dt: float,
    qdot: FloatArray,
    pd: PairDistances,
    s: float,
    k: int,
) -> tuple[float, int]:
    """:func:`distance_shield`'s scale ``s`` checked on the true geometry: the pairs'
    distances at ``q + dt s q̇`` and ``t + dt`` (one more query, only when a pair is predicted
    within ``d_influence``). The first-order prediction misses the distance's curvature
    (a link swinging past a post by several cm a period lands up to 0.2 mm under ``d_s``);
    while a pair would land under ``min(d_s, its distance at rest)``, ``s`` shrinks by 0.6
    (at most 8 times, then 0). Returns ``(s, k)`` as :func:`distance_shield` does."""
    geo = c.compiled(robot)
    if geo is not None:  # static obstacles: the kernel, as the compiled loop does
        return geo.exact_scale(q, qdot, pd.d, pd.J, (s, k), (dt, c.d_safe, c.d_influence))
    rest = pd.d + dt * pd.drift
    if s <= 0.0 or not np.any(rest + dt * s * (pd.J @ qdot) < c.d_influence):
        return s, k
    floor = np.minimum(c.d_safe, rest)
    for _ in range(8):
        gap = c.measure(robot, q + dt * s * qdot, t + dt).d - floor
        j = int(np.argmin(gap))
        if gap[j] >= 0.0:
            return s, k
        s, k = 0.6 * s, j
    return 0.0, k


@dataclass
class CollisionAvoidance:
    """The repulsive objective of a :class:`Collision` (module docstring): ``q̇_rep`` as the
    law's ``secondary`` (nothing when the collision set-up is off or not avoiding)."""

    collision: Collision

    def __call__(self, ctx: ObjectiveContext) -> tuple[FloatArray | None, str | None]:
        c = self.collision
        if not (c.enabled and c.avoid and c.repel and c.active):
            return None, None
        if ctx.robot is None:
            raise ConfigurationError(
                "CollisionAvoidance needs the controller's model robot", argument="objectives"
            )
        pd = c.measure(ctx.robot, ctx.q, ctx.t)
        cmd = repulsive_command(
            pd.d, pd.J, d_safe=c.d_safe, d_influence=c.d_influence, xi=c.xi, damping=c.damping
        )
        return cmd, None
