"""The predictive law's horizon QP: its constraints and its solve (docs/predictive.md).

:func:`horizon_qp` builds the QP of one step of :class:`~redservo.redundancy.predictive.
Predictive` (the model's prediction over the horizon, the joint bounds less the band, the
rate limits, the image bounds, the effort, the joint goal, the camera-motion rows and, with
collision avoidance on, the velocity-damper rows on the first command and the distance
rows over the horizon, :mod:`redservo.redundancy.predictive_distance`);
:func:`solve_horizon` solves it with daqp. Units: rad or m, s; commands in rad/s or m/s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import flagbits as fb
from redservo.redundancy.base import LawInputs
from redservo.redundancy.bls import daqp_once
from redservo.redundancy.distance_rows import distance_rows
from redservo.redundancy.predictive_camera import MotionLimit, damped_image_bounds, motion_rows
from redservo.redundancy.predictive_distance import with_horizon_rows
from redservo.redundancy.predictive_model import QP, Prediction, build_qp, local_prediction
from redservo.redundancy.safety import position_box

if TYPE_CHECKING:
    from redservo.redundancy.predictive import Model, Predictive

__all__ = ["horizon_qp", "solve_horizon"]


def horizon_qp(
    law: Predictive, x: LawInputs, U: FloatArray, model: Model | None, motion: MotionLimit | None
) -> QP | None:
    """The horizon QP of one step (MPC over ``law``'s horizon, docs/predictive.md): the
    prediction of ``model`` (or the local one of ``J1``, ``e1``), the joint bounds less the
    band, the rate limits, the image bounds, the effort, the joint goal and the
    camera-motion rows; None when the model cannot predict. ``U`` the warm start (N, n),
    rad/s or m/s."""
    hz, lim = law._hz, x.limits
    pred: Prediction | None
    if model is not None:
        pred = model.predict(x.q, U, hz, x.dt)
        if pred is None:
            return None
    else:
        pred = local_prediction(x.J1, x.e1, U, hz, x.dt)
    band = law._band(x)
    s_now = None if model is None else model.s_now
    s_lo, s_hi = _image_bounds(law, pred, s_now, hz.N)
    sigma = float(np.linalg.norm(x.J1, 2)) if x.J1.size else 1.0
    rho = law.effort * (x.dt * max(sigma, 1e-9)) ** 2
    ff = None if x.de1_dt is None else x.de1_dt
    goal = None
    if model is not None and law._goal is not None:
        goal = (law._goal, law.goal_weight * sigma**2)
    qp = build_qp(
        pred,
        U,
        hz,
        x.dt,
        q0=x.q,
        q_lo=lim.q_min + band,
        q_hi=lim.q_max - band,
        v_max=lim.qdot_max,
        a_max=lim.qddot_max,
        qdot_prev=x.qdot_prev,
        s_lo=s_lo,
        s_hi=s_hi,
        effort=rho,
        ff=ff,
        goal=goal,
        s_now=s_now,
        u0_box=position_box(x.q, lim, x.dt) if law.shield else None,
    )
    qp = with_horizon_rows(with_distance_rows(qp, law, x.q), law, x.q, U, hz, x.dt)
    if motion is None or pred.s is None or s_now is None:
        return qp
    rows, blo, bhi = motion_rows(pred, hz, x.dt, U, s_now, motion)
    return qp._replace(
        A=np.vstack([qp.A, *rows]),
        blo=np.concatenate([qp.blo, *blo]),
        bhi=np.concatenate([qp.bhi, *bhi]),
    )


def _image_bounds(
    law: Predictive, pred: Prediction, s_now: FloatArray | None, N: int
) -> tuple[FloatArray | None, FloatArray | None]:
    """The image bounds of the points (normalized): the image less ``image_margin_px``,
    (2p,) each, or with a tracker bound (a camera) damped over the horizon, (N, 2p) each
    (:func:`~redservo.redundancy.predictive_camera.damped_image_bounds`); None without
    predicted points (the local model)."""
    if pred.s is None:
        return None, None
    cam, mpx, p = law._camera, law.image_margin_px, pred.s.shape[1] // 2
    s_lo = np.tile([(mpx - cam.u0) / cam.px, (mpx - cam.v0) / cam.py], p)
    s_hi = np.tile([(cam.width - mpx - cam.u0) / cam.px, (cam.height - mpx - cam.v0) / cam.py], p)
    if law._gate_px is None:
        return s_lo, s_hi
    return damped_image_bounds(s_lo, s_hi, pred.s[0] if s_now is None else s_now, N)


def with_distance_rows(qp: QP, law: Predictive, q: FloatArray) -> QP:
    """``qp`` with the velocity-damper rows ``J_k u₀ ≥ b_k`` on the first command ``u₀``
    (:mod:`redservo.redundancy.distance_rows`; the command applied before the next
    measurement), capped at "never closer" (``b_k ≤ 0``) so that rest stays feasible."""
    rows = distance_rows(law, q)
    if rows is None:
        return qp
    G = np.zeros((rows.b.size, qp.A.shape[1]))
    G[:, : rows.G.shape[1]] = rows.G
    b = np.minimum(rows.b, 0.0)
    return qp._replace(
        A=np.vstack([qp.A, G]),
        blo=np.concatenate([qp.blo, b]),
        bhi=np.concatenate([qp.bhi, np.full(b.size, 1e30)]),
    )


def solve_horizon(
    qp: QP, start: FloatArray, max_iterations: int
) -> tuple[FloatArray, int, float, int]:
    """``(U, why, value, iterations)``: daqp on ``qp`` (at most ``max_iterations``); ``why``
    = 0 or the flag bit (``start`` is returned when the solve fails)."""
    daqp = daqp_once()
    if daqp is None:  # pragma: no cover - daqp is a dependency of the qp extra
        return start, fb.HORIZON_INFEASIBLE, float("nan"), 0
    bu = np.concatenate([qp.hi, qp.bhi])
    bl = np.concatenate([qp.lo, qp.blo])
    sense = np.zeros(bu.size, dtype=np.intc)
    y, _, flag, info = daqp.solve(
        qp.H,
        qp.f,
        qp.A,
        bu,
        bl,
        sense,
        iter_limit=max_iterations,
    )
    iters = int(info.get("iterations", 0))
    if flag == -4:
        return start, fb.SOLVER_ITERATIONS, float(iters), iters
    if flag <= 0 or not np.all(np.isfinite(y)):
        return start, fb.HORIZON_INFEASIBLE, float(flag), iters
    U = np.clip(y, qp.lo, qp.hi).reshape(start.shape)
    return U, 0, 0.0, iters
