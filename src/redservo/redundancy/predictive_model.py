"""The prediction model and the horizon QP of the ``predictive`` law (docs/predictive.md).

The decision variables are the joint velocities of ``Nc`` blocks (move blocking):
``U = (u_0, …, u_{Nc-1})`` (rad/s or m/s, stacked row-wise), the velocity of period
``i = 0…N-1`` is ``u_{b(i)}`` with ``b(i) = min(i, Nc-1)`` (the last block is held to the end
of the prediction horizon ``N``; Allibert, Courtial & Chaumette 2010 call ``Nc`` the control
horizon, cf. their §III). Then the predicted joints are, for ``k = 1…N``::

    q_k = q_0 + dt Σ_j M[k-1, j] u_j,     M[k-1, j] = #{i < k : b(i) = j}

and the predicted task error is linearised around the previous (shifted) solution ``Ū``::

    e_k(U) ≈ ē_k + dt G_k Σ_j M[k-1, j] (u_j - ū_j)

* **global model** (Allibert 2010's nonlinear model, cf. §III-B): the camera's own kinematics
  ``bMc(q̄_k)``, ``J(q̄_k)`` and the projection of the target's points, fixed in the base frame
  where the last measurement put them (``P_b = bMc(q_0) (x/ζ, y/ζ, 1/ζ)``, ``ζ = 1/Z``):
  ``s_k = π(cMb(q̄_k) P_b)``, ``ē_k = C (s_k - s*)``, ``G_k = C L(s_k, ζ_k) J(q̄_k)``.
* **local model** (cf. §III-C): ``L`` constant, ``ē_k = e_0 + dt J1 Σ M ū``, ``G_k = J1``.

Units: seconds, metres, radians, normalized image coordinates.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from redservo._validation import FloatArray

if TYPE_CHECKING:  # the robots (and scipy through them) are not imported with the laws
    from redservo.robots.base import Robot

__all__ = [
    "Horizon",
    "PointModel",
    "Prediction",
    "SeenJoints",
    "horizon",
    "point_model",
    "point_prediction",
]

BIG = 1e9
"""Stand-in for an absent bound (daqp takes finite bounds)."""


class Horizon(NamedTuple):
    """The move-blocking structure: ``N`` periods, ``Nc`` blocks, the (N, Nc) matrix ``M``."""

    N: int
    Nc: int
    M: FloatArray
    ends: tuple[int, ...]
    """The periods ``k`` (1…N) at which a block ends: the predicted joints are extremal there."""


def horizon(N: int, Nc: int) -> Horizon:
    """The :class:`Horizon` of ``N`` periods and ``min(Nc, N)`` blocks."""
    Nc = min(Nc, N)
    M = np.zeros((N, Nc))
    for k in range(1, N + 1):
        for i in range(k):
            M[k - 1, min(i, Nc - 1)] += 1.0
    ends = tuple(sorted({*range(1, Nc), N}))
    return Horizon(N, Nc, M, ends)


class PointModel(NamedTuple):
    """What the global model needs: the model robot, the target's points in the base frame
    (p, 3) (m), ``C`` (m, 2p) or None, ``s*`` (2p,)."""

    robot: Robot
    P_b: FloatArray
    C: FloatArray | None
    s_star: FloatArray
    s_now: FloatArray | None = None
    """(2p,) the points' normalized image coordinates where the model was built."""

    def predict(self, q0: FloatArray, U: FloatArray, hz: Horizon, dt: float) -> Prediction | None:
        """:func:`point_prediction` of this model."""
        return point_prediction(self, q0, U, hz, dt)


def point_model(
    robot: Robot,
    task: Any,
    state: Any,
    q: FloatArray,
    q_seen: FloatArray | None = None,
    Pc: FloatArray | None = None,
) -> PointModel | None:
    """The :class:`PointModel` of a task of image points of one target from its evaluated
    ``state`` (``s``, ``inv_depth``) at ``q``: the measured points put in the base frame
    where the camera saw them, ``P_b = bMc(q_seen) (x/ζ, y/ζ, 1/ζ)`` (``q_seen``: the joints
    when the image was exposed, :class:`SeenJoints`; None: ``q``), ``s_now`` their projection
    at ``q`` (the measurement brought to the present); ``Pc`` (p, 3): the points in the
    camera frame then (m) when known otherwise (a pose estimate), instead of the measured
    points at their depths; None when a depth is not positive or a point not finite."""
    xy = np.asarray(state.s, dtype=float).reshape(-1, 2)
    iz = np.array([float(np.asarray(d).reshape(-1)[0]) for d in state.inv_depth])
    if xy.shape[0] != iz.shape[0] or not np.all(iz > 0) or not np.all(np.isfinite(xy)):
        return None
    if Pc is None:
        Pc = np.c_[xy / iz[:, None], 1.0 / iz]
    seen = robot.kinematics(q if q_seen is None else q_seen, check_limits=False)[0]
    bMc = seen if q_seen is None else robot.kinematics(q, check_limits=False)[0]
    s_star = np.asarray(task.s_star, dtype=float)
    P_b = Pc @ seen[:3, :3].T + seen[:3, 3]
    back = (P_b - bMc[:3, 3]) @ bMc[:3, :3]  # the model's own projection at q
    return PointModel(robot, P_b, task.C, s_star, (back[:, :2] / back[:, 2:3]).reshape(-1))


class SeenJoints:
    """The joints at which the camera exposed a measurement ``latency`` seconds old: the
    joints of the past calls (one a period ``dt``, s), linearly interpolated; the oldest
    kept when the run is younger than the latency (the Smith-predictor view of the
    measurement: the points are put in the base frame where the camera saw them, and the
    motion since is the model's)."""

    def __init__(self, latency: float) -> None:
        self.latency = float(latency)
        self._past: list[FloatArray] = []

    def reset(self) -> None:
        """Forget the past joints."""
        self._past = []

    def push(self, q: FloatArray, dt: float) -> FloatArray | None:
        """Record ``q`` (the joints now) and return the joints ``latency`` ago (None without
        a latency)."""
        if self.latency <= 0.0:
            return None
        back = self.latency / dt if dt > 0 else 0.0
        self._past.append(np.array(q, dtype=float))
        keep = int(np.ceil(back)) + 1
        del self._past[:-keep]
        pos = max(0.0, len(self._past) - 1 - back)  # fractional index of the exposure
        i = min(int(pos), len(self._past) - 1)
        j = min(i + 1, len(self._past) - 1)
        w = pos - i
        return np.asarray((1.0 - w) * self._past[i] + w * self._past[j])


class Prediction(NamedTuple):
    """The predictions along the horizon at the linearisation point ``Ū``.

    ``e`` (N, m) the task errors ``ē_k``; ``G`` (N, m, n) their Jacobians ``∂e_k/∂q_k``;
    ``s`` (N, 2p) and ``S`` (N, 2p, n) the image points and their Jacobians (None for the
    local model: no visibility constraint).
    """

    e: FloatArray
    G: FloatArray
    s: FloatArray | None
    S: FloatArray | None


def _points_interaction(xy: FloatArray, iz: FloatArray) -> FloatArray:
    """Stacked (2p, 6) interaction matrices of normalized points (CM01 eq. 26)."""
    x, y = xy[:, 0], xy[:, 1]
    L = np.empty((xy.shape[0], 2, 6))
    L[:, 0] = np.stack([-iz, 0 * iz, x * iz, x * y, -(1 + x * x), y], axis=1)
    L[:, 1] = np.stack([0 * iz, -iz, y * iz, 1 + y * y, -x * y, -x], axis=1)
    return L.reshape(-1, 6)


def point_prediction(
    model: PointModel, q0: FloatArray, U: FloatArray, hz: Horizon, dt: float
) -> Prediction | None:
    """The global model's predictions at ``U`` (Nc, n) from ``q0`` (None: a point would be
    at or behind the camera plane along the horizon, or the kinematics not finite)."""
    N, n = hz.N, q0.shape[0]
    k2 = model.s_star.shape[0]
    m = k2 if model.C is None else model.C.shape[0]
    e, G = np.empty((N, m)), np.empty((N, m, n))
    s, S = np.empty((N, k2)), np.empty((N, k2, n))
    Ph = np.c_[model.P_b, np.ones(len(model.P_b))]
    for k in range(1, N + 1):
        qk = q0 + dt * (hz.M[k - 1] @ U)
        bMc, J = model.robot.kinematics(qk, check_limits=False)
        R, t = bMc[:3, :3], bMc[:3, 3]
        Pc = (Ph[:, :3] - t) @ R  # cMb P_b = R^T (P_b - t)
        if not np.all(Pc[:, 2] > 1e-6) or not np.all(np.isfinite(J)):
            return None
        iz = 1.0 / Pc[:, 2]
        xy = Pc[:, :2] * iz[:, None]
        sk = xy.reshape(-1)
        Sk = _points_interaction(xy, iz) @ J
        s[k - 1], S[k - 1] = sk, Sk
        if model.C is None:
            e[k - 1], G[k - 1] = sk - model.s_star, Sk
        else:
            e[k - 1], G[k - 1] = model.C @ (sk - model.s_star), model.C @ Sk
    return Prediction(e, G, s, S)


def local_prediction(
    J1: FloatArray, e0: FloatArray, U: FloatArray, hz: Horizon, dt: float
) -> Prediction:
    """The local model's predictions at ``U``: ``ē_k = e_0 + dt J1 Σ_j M[k-1, j] ū_j``."""
    steps = hz.M @ U  # (N, n)
    e = e0[None, :] + dt * steps @ J1.T
    G = np.broadcast_to(J1, (hz.N, *J1.shape))
    return Prediction(e, np.asarray(G), None, None)


class QP(NamedTuple):
    """``min ½ xᵀHx + fᵀx`` s.t. ``lo <= x <= hi`` (simple) and ``blo <= A x <= bhi``."""

    H: FloatArray
    f: FloatArray
    lo: FloatArray
    hi: FloatArray
    A: FloatArray
    blo: FloatArray
    bhi: FloatArray


def _block(hz: Horizon, k: int, G: FloatArray, dt: float) -> FloatArray:
    """``∂(·)_k/∂U``: ``dt [M[k-1,0] G, …, M[k-1,Nc-1] G]`` for a (r, n) Jacobian ``G``."""
    return dt * np.concatenate([hz.M[k - 1, j] * G for j in range(hz.Nc)], axis=1)


def _simple_bounds(
    Nc: int,
    n: int,
    dt: float,
    v_max: FloatArray | None,
    a_max: FloatArray | None,
    qdot_prev: FloatArray | None,
    u0_box: tuple[FloatArray, FloatArray] | None,
) -> tuple[FloatArray, FloatArray]:
    """``(lo, hi)`` (Nc n,) of :func:`build_qp`: the velocity limits on every block, the
    acceleration limit from ``qdot_prev`` and the shield's box on the first."""
    v = np.full(n, BIG) if v_max is None else v_max
    lo, hi = np.tile(-v, Nc), np.tile(v, Nc)
    if a_max is not None and qdot_prev is not None:
        lo[:n] = np.maximum(lo[:n], qdot_prev - a_max * dt)
        hi[:n] = np.minimum(hi[:n], qdot_prev + a_max * dt)
        lo[:n] = np.minimum(lo[:n], hi[:n])
    if u0_box is not None:  # the shield's box (braking bound), where it meets the rate box
        b_lo, b_hi = np.maximum(lo[:n], u0_box[0]), np.minimum(hi[:n], u0_box[1])
        ok = b_lo <= b_hi
        lo[:n], hi[:n] = np.where(ok, b_lo, lo[:n]), np.where(ok, b_hi, hi[:n])
    return lo, hi


def _add_acceleration_rows(
    rows: list[FloatArray],
    blo: list[FloatArray],
    bhi: list[FloatArray],
    Nc: int,
    n: int,
    a_max: FloatArray,
    dt: float,
) -> None:
    """Append the rows ``-a_max dt ≤ u_j - u_{j-1} ≤ a_max dt`` between consecutive blocks.

    ``a_max`` (n,) in rad/s² (m/s² for prismatic joints), ``dt`` in s; the rows act on the
    stacked block velocities ``U`` (``Nc · n``, rad/s or m/s).
    """
    nv = Nc * n
    for j in range(1, Nc):
        D = np.zeros((n, nv))
        D[:, j * n : (j + 1) * n] = np.eye(n)
        D[:, (j - 1) * n : j * n] = -np.eye(n)
        rows.append(D)
        blo.append(-a_max * dt)
        bhi.append(a_max * dt)


def build_qp(
    pred: Prediction,
    Ubar: FloatArray,
    hz: Horizon,
    dt: float,
    *,
    q0: FloatArray,
    q_lo: FloatArray,
    q_hi: FloatArray,
    v_max: FloatArray | None,
    a_max: FloatArray | None,
    qdot_prev: FloatArray | None,
    s_lo: FloatArray | None,
    s_hi: FloatArray | None,
    effort: float,
    ff: FloatArray | None,
    goal: tuple[FloatArray, float] | None = None,
    s_now: FloatArray | None = None,
    u0_box: tuple[FloatArray, FloatArray] | None = None,
) -> QP:
    """The QP of one SQP iteration (docs/predictive.md, "Formulation").

    Cost ``Σ_k ‖e_k(U)‖² / N + ρ ‖U − Ū‖²`` (``ρ = effort``, absolute, (task units · s)²:
    a damping of the step from the linearisation point, which leaves the converged plan
    unbiased);
    simple bounds from the velocity limits and, on ``u_0``, the acceleration limit from
    ``qdot_prev``; rows: joint positions at the block ends within ``[q_lo, q_hi]``,
    acceleration between blocks, image points within ``[s_lo, s_hi]`` at every period
    (each (2p,), or (N, 2p): the bounds of each period).
    ``ff`` (m,) adds the known drift ``k dt ∂e/∂t`` of a moving target to ``ē_k``;
    ``goal = (q*, γ)`` adds the terminal cost ``γ ‖q_N - q*‖²``; ``s_now`` (2p,): the
    measured points, whose image bounds are relaxed to them when they are already outside;
    ``u0_box = (lo, hi)`` (n,): the position shield's velocity box (its braking bound) on
    the first block, where it meets the rate box, so that the shield leaves the command as
    it is.
    """
    N, Nc = hz.N, hz.Nc
    n = q0.shape[0]
    nv = Nc * n
    ub = Ubar.reshape(-1)
    H = effort * np.eye(nv)
    f = -effort * ub
    for k in range(1, N + 1):
        Ak = _block(hz, k, pred.G[k - 1], dt)
        rk = pred.e[k - 1] - Ak @ ub
        if ff is not None:
            rk = rk + k * dt * ff
        H += Ak.T @ Ak / N
        f += Ak.T @ rk / N
    if goal is not None:
        AN = _block(hz, N, np.eye(n), dt)
        H += goal[1] * AN.T @ AN
        f += goal[1] * AN.T @ (q0 - goal[0])
    lo, hi = _simple_bounds(Nc, n, dt, v_max, a_max, qdot_prev, u0_box)
    rows, blo, bhi = [], [], []
    for k in hz.ends:  # positions: q_0 + dt M[k-1] U, extremal at the block ends
        rows.append(_block(hz, k, np.eye(n), dt))
        blo.append(np.minimum(q_lo, q0) - q0)
        bhi.append(np.maximum(q_hi, q0) - q0)
    if a_max is not None:
        _add_acceleration_rows(rows, blo, bhi, Nc, n, a_max, dt)
    if pred.s is not None and pred.S is not None and s_lo is not None and s_hi is not None:
        s0 = pred.s[0] if s_now is None else s_now  # relax only what is already violated
        lo_s, hi_s = np.minimum(s_lo, s0), np.maximum(s_hi, s0)
        for k in range(1, N + 1):
            Bk = _block(hz, k, pred.S[k - 1], dt)
            rows.append(Bk)
            base = pred.s[k - 1] - Bk @ ub
            blo.append((lo_s if lo_s.ndim == 1 else lo_s[k - 1]) - base)
            bhi.append((hi_s if hi_s.ndim == 1 else hi_s[k - 1]) - base)
    return QP(H, f, lo, hi, np.vstack(rows), np.concatenate(blo), np.concatenate(bhi))
