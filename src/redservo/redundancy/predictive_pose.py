"""The target's pose for the ``predictive`` law's point model, from the measured image points
and the target's known points (docs/predictive.md, "Depths of the model").

The global model puts the target's points in the base frame from the measured points and
their depths. Through a camera the depths are not measured: the image sensor gives the
desired depths (``depth = "desired"``) or an estimate, off by tens of percent away from the
goal. A model with wrong depths predicts wrong image motion, and the optimiser then finds
motions whose translation and rotation cancel in the model but not on the camera (measured:
2 px predicted, 25 px on the camera). The task's point features know the target's points in
its own frame (``PointFeature.point_o``), so the law estimates the target's pose ``cMo`` from
the measured points (virtual visual servoing, Gauss-Newton on the reprojection error,
warm-started at the previous period's pose or at a rigid fit of the points placed at the
given depths) and takes the depths from it. With exact features it returns the true pose.

Units: metres, normalized image coordinates.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.redundancy.predictive_model import PointModel, point_model
from redservo.redundancy.predictive_model import _points_interaction as points_interaction

__all__ = ["ITERATIONS", "RESIDUAL", "PosePoints", "points_pose", "rigid_fit", "target_points"]

ITERATIONS = 30
"""Gauss-Newton iterations of the pose estimate at most."""
RESIDUAL = 5e-3
"""Largest RMS reprojection error (normalized units, about 3 px at 600 px) of an accepted
pose: above it (a wrong local minimum, a wrong target model) the given depths are kept."""


def rigid_fit(P_o: FloatArray, P_c: FloatArray) -> FloatArray:
    """``cMo`` (4, 4): the rotation and translation taking the points ``P_o`` (p, 3) nearest
    to ``P_c`` (p, 3) in least squares (Kabsch, without reflection)."""
    o, c = P_o.mean(axis=0), P_c.mean(axis=0)
    U, _, Vt = np.linalg.svd((P_o - o).T @ (P_c - c))
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0)])
    R = Vt.T @ D @ U.T
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c - R @ o
    return T


def points_pose(
    P_o: FloatArray, xy: FloatArray, iz: FloatArray, guess: FloatArray | None
) -> FloatArray | None:
    """``cMo`` (4, 4) whose projection of ``P_o`` (p, 3) is nearest the measured ``xy``
    (p, 2), from ``guess`` (None: :func:`rigid_fit` of the points at the inverse depths
    ``iz``, p), or None (fewer than 3 points, a point at or behind the camera, or an RMS
    error above :data:`RESIDUAL`)."""
    from redservo.spatial import exp_twist  # scipy: not loaded by ``import redservo``

    if P_o.shape[0] < 3:
        return None
    T = rigid_fit(P_o, np.c_[xy / iz[:, None], 1.0 / iz]) if guess is None else guess.copy()
    target = xy.reshape(-1)
    rms = np.inf
    for _ in range(ITERATIONS):
        Pc = P_o @ T[:3, :3].T + T[:3, 3]
        if not np.all(Pc[:, 2] > 1e-6):
            return None
        z = 1.0 / Pc[:, 2]
        proj = Pc[:, :2] * z[:, None]
        e = proj.reshape(-1) - target
        rms = float(np.sqrt(np.mean(e * e)))
        v = -np.linalg.lstsq(points_interaction(proj, z), e, rcond=None)[0]
        if not np.all(np.isfinite(v)):
            return None
        T = np.linalg.inv(exp_twist(v)) @ T
        if float(np.linalg.norm(v)) < 1e-12:
            break
    return T if rms < RESIDUAL else None


def target_points(task: Any) -> FloatArray:
    """The target's points in its own frame (p, 3), one per point term of ``task`` (m)."""
    return np.array([t.feature.point_o for t in task.terms], dtype=float)


class PosePoints:
    """The point model's builder with the depths from the target's pose (module docstring),
    warm-started at the previous period's pose ``bMo`` (4, 4; base frame, m)."""

    def __init__(self) -> None:
        self.bMo: FloatArray | None = None

    def reset(self) -> None:
        """Forget the previous pose."""
        self.bMo = None

    def builder(
        self, robot: Any, task: Any, state: Any
    ) -> Callable[[FloatArray, FloatArray | None], PointModel | None]:
        """``build(q, q_seen)``: :func:`~redservo.redundancy.predictive_model.point_model`
        with the points from :func:`points_pose` (the measured depths when it fails)."""
        P_o = target_points(task)

        def build(q: FloatArray, seen: FloatArray | None) -> PointModel | None:
            bMc = robot.kinematics(q if seen is None else seen, check_limits=False)[0]
            xy = np.asarray(state.s, dtype=float).reshape(-1, 2)
            iz = np.array([float(np.asarray(d).reshape(-1)[0]) for d in state.inv_depth])
            guess = None if self.bMo is None else np.linalg.inv(bMc) @ self.bMo
            with np.errstate(all="ignore"):
                cMo = points_pose(P_o, xy, iz, guess)
                if cMo is None and guess is not None:  # a stale warm start: from the depths
                    cMo = points_pose(P_o, xy, iz, None)
            self.bMo = None if cMo is None else bMc @ cMo
            Pc = None if cMo is None else P_o @ cMo[:3, :3].T + cMo[:3, 3]
            return point_model(robot, task, state, q, seen, Pc)

        return build
