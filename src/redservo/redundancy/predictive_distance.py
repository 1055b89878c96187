"""The ``predictive`` law's distance rows over its whole horizon (issue 30; docs/predictive.md).

With collision avoidance on, the law already has the velocity-damper rows on its first
command (:mod:`redservo.redundancy.distance_rows`). Those see one period ahead only: the
plan's later blocks may run a link into a post, and the law finds out when the damper and
the shield stop it there. Here every predicted period ``k = 1…N`` gets the pairs' distance,
measured by the same kernel (:meth:`~redservo.control.avoidance.Collision.measure`'s; with
compiled geometry one call for the whole plan, the pairs beyond ``d_influence`` skipped by the
broad phase: :func:`~redservo.kernels.horizon_distance.measure_plan`, the same bits) at the
linearisation point ``q̄_k = q_0 + dt Σ_j M[k-1, j] ū_j`` (the warm start ``Ū``) and
linearised there, as the image points are::

    d_k(U) ≈ d̄_k + J_k (q_k − q̄_k) = d̄_k + dt J_k Σ_j M[k-1, j] (u_j − ū_j)  ≥  d_s

for every pair within ``d_influence`` at ``q̄_k`` (``d`` in m, ``J_k`` in m/rad or m/m,
``d_s`` = ``d_safe``). The bound is capped so that rest (``U = 0``, the joints where they
are) always meets it: a row never asks more than "no closer along this linearisation than
standing still", so the rows cannot make the horizon infeasible where the robot at rest
is feasible. The linearisation is the plan's, not a guarantee: the first-command damper
rows and the distance shield (on the true geometry) still guard the command applied.

Units: metres, seconds, radians.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.redundancy.distance_rows import _SOURCE

if TYPE_CHECKING:  # the kernel module, typed; imported on first use at run time
    from redservo.collision.pack import CompiledGeometry
    from redservo.control.avoidance import Collision
    from redservo.kernels import horizon_distance as _K
    from redservo.redundancy.predictive_model import QP, Horizon
    from redservo.robots.base import Robot
else:
    _K = lazy("horizon_distance")

__all__ = [
    "HorizonRows",
    "clear_of",
    "distance_source",
    "goal_clearance",
    "horizon_distance_rows",
    "static_scene",
    "with_horizon_rows",
]

_INF = 1e30
"""daqp's infinite bound."""


class HorizonRows(NamedTuple):
    """``A U ≥ b`` on the stacked blocks ``U`` (Nc n,) for the pairs near the plan."""

    A: FloatArray
    """(r, Nc n) ``dt J_k [M[k-1, 0], …, M[k-1, Nc-1]]`` per row (m per rad/s or m/s)."""
    b: FloatArray
    """(r,) the bounds (m), at most 0 (rest meets them)."""
    steps: tuple[int, ...]
    """(r,) the predicted period ``k`` (1…N) of each row."""
    names: tuple[str, ...]
    """(r,) the pairs."""


def distance_source(law: object) -> tuple[Collision, Robot] | None:
    """The collision set-up and robot bound to ``law`` (None: not avoiding)."""
    src: tuple[Collision, Robot] | None = getattr(law, _SOURCE, None)
    return src


def horizon_distance_rows(
    law: Any, q0: FloatArray, Ubar: FloatArray, hz: Horizon, dt: float
) -> HorizonRows | None:
    """The rows of the module docstring for ``law`` (bound by
    :func:`~redservo.redundancy.distance_rows.bind_distances`) at ``q0`` (n,) with the warm
    start ``Ubar`` (Nc, n), horizon ``hz`` and period ``dt`` (s); None when the law is not
    avoiding or no pair comes within ``d_influence`` along the predicted path."""
    src = distance_source(law)
    if src is None:
        return None
    c, robot = src
    Q = [q0 + (dt * hz.M[k - 1]) @ Ubar for k in range(1, hz.N + 1)]
    geo = c.compiled(robot)
    if geo is None:  # coal: every pair at each period (the same pairs at each)
        t0 = c.last_time
        per_k = [c.probe(robot, qk, t0 + k * dt) for k, qk in enumerate(Q, start=1)]
        D, JJ = np.array([pd.d for pd in per_k]), np.array([pd.J for pd in per_k])
        return _rows(D, JJ, per_k[0].names, hz, dt, Ubar, c)
    # One compiled call for the plan, the pairs beyond d_influence skipped (d = inf).
    D, JJ = _K.measure_plan(np.array(Q), geo.arm, geo.geom, c.d_influence)
    return _rows(D, JJ, geo.names, hz, dt, Ubar, c)


def _rows(
    D: FloatArray,
    JJ: FloatArray,
    pairs: tuple[str, ...],
    hz: Horizon,
    dt: float,
    Ubar: FloatArray,
    c: Collision,
) -> HorizonRows | None:
    """The rows from the distances ``D`` (N, P) and Jacobians ``JJ`` (N, P, n) of the
    pairs ``pairs`` at the predicted periods ``k = 1…N``: period by period, each pair in
    turn. Each row's block ``j`` is ``dt M[k-1, j] J`` and its bound ``d_s − d̄ + A ū``
    (``A ū`` one matrix-vector product per period, as the rows were built one period at a
    time: BLAS rounds a product by its shape)."""
    ks, ps = np.nonzero(D < c.d_influence)
    if ks.size == 0:
        return None
    W = dt * hz.M  # (N, Nc): row k-1 is period k's weights
    A = (W[ks][:, :, None] * JJ[ks, ps][:, None, :]).reshape(ks.size, -1)
    ub = Ubar.reshape(-1)
    cuts = [0, *(np.flatnonzero(np.diff(ks)) + 1).tolist(), ks.size]
    Au = np.concatenate([A[i:j] @ ub for i, j in itertools.pairwise(cuts)])
    # d̄ + A (U − ū) ≥ d_s  ⇔  A U ≥ d_s − d̄ + A ū; capped at 0 (rest: A·0 = 0).
    b = np.minimum(c.d_safe - D[ks, ps] + Au, 0.0)
    return HorizonRows(A, b, tuple((ks + 1).tolist()), tuple(pairs[p] for p in ps))


def with_horizon_rows(
    qp: QP, law: Any, q0: FloatArray, Ubar: FloatArray, hz: Horizon, dt: float
) -> QP:
    """``qp`` (:class:`~redservo.redundancy.predictive_model.QP`) with the rows of
    :func:`horizon_distance_rows` (``b ≤ A U``, no upper bound); unchanged without them."""
    rows = horizon_distance_rows(law, q0, Ubar, hz, dt)
    if rows is None:
        return qp
    return qp._replace(
        A=np.vstack([qp.A, rows.A]),
        blo=np.concatenate([qp.blo, rows.b]),
        bhi=np.concatenate([qp.bhi, np.full(rows.b.size, _INF)]),
    )


def goal_clearance(law: object) -> Callable[[FloatArray], bool] | None:
    """``clear(q)`` for the law's joint-goal search
    (:func:`~redservo.redundancy.predictive_goal.search_steps`): every pair at least
    ``d_safe`` apart at ``q`` (rad or m), the criterion of the campaigns' reachability
    (:mod:`redservo.campaign.reach_obstacles`); None when the law is not avoiding. A goal
    inside an obstacle pulls the plan, through the terminal cost, against the distance rows,
    where the arm stays held at ``d_safe``."""
    src = distance_source(law)
    if src is None:
        return None
    c, robot = src
    geo = c.compiled(robot)
    if geo is not None:
        return clear_of(geo, c.d_safe)

    def clear(q: FloatArray) -> bool:
        d = c.probe(robot, q, c.last_time).d
        return bool(d.size == 0 or float(np.min(d)) >= c.d_safe)

    return clear


def clear_of(geo: CompiledGeometry, d_safe: float) -> Callable[[FloatArray], bool]:
    """``clear(q)``: every pair of the compiled geometry ``geo`` at least ``d_safe`` (m)
    apart at ``q`` (rad or m), the pairs that cannot be closer skipped
    (:func:`~redservo.kernels.horizon_distance.measure_plan` with the threshold ``d_safe``:
    the smallest distance is the full measurement's whenever it is below ``d_safe``)."""
    arm, geom = geo.arm, geo.geom

    def clear(q: FloatArray) -> bool:
        Q = np.array(q, dtype=np.float64, ndmin=2)
        d = _K.measure_plan(Q, arm, geom, d_safe)[0][0]
        return bool(d.size == 0 or float(np.min(d)) >= d_safe)

    return clear


def static_scene(law: object) -> bool:
    """Whether ``law`` avoids collisions among obstacles that do not move (self pairs only
    count as static): the joint-goal search's memo and deferred restarts hold then
    (:mod:`redservo.redundancy.predictive_replan`)."""
    from redservo.scene import Static

    src = distance_source(law)
    return src is not None and all(isinstance(ob.trajectory, Static) for ob in src[0].obstacles)
