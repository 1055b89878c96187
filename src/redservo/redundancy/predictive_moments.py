"""The ``predictive`` law's global model of the six moment features (docs/predictive.md).

The moment features of coplanar points (:class:`~redservo.features.MomentFeatures`, MC05
§IV, Tahri & Chaumette 2005) are a function of the object's pose ``cMo``; the feature knows
the object's points ``points_o`` (its model), the measurement gives ``s`` and the object
plane ``(A, B, C)``. The law needs the target's pose in the base frame, ``bMo``, so that the
model robot's kinematics predict the features along the horizon
(``s_k = s(cMb(q̄_k) bMo)``, ``G_k = C L_s(s_k) J(q̄_k)``, MC05 eq. 5 for ``J1``), as the
point model does with the points (Allibert, Courtial & Chaumette 2010's global model).

``cMo`` is estimated from the measured features and object plane: Gauss-Newton on the pose
(the residual ``(s(cMo) − s, w (plane(cMo) − plane))``, :data:`PLANE_WEIGHT`, the camera
moving by the step twist in its own frame, ``cMo ← exp(v_c)⁻¹ cMo``), warm-started from the
previous period's ``bMo`` (the target is still in the base frame), else from the plane and
the centroid with 16 turns about the plane normal, the best kept. A plane that no pose
shares with the features is not a measurement but a depth policy (the image sensor's
``depth = "desired"``: the plane parallel to the image at the desired depth): the pose is
then the features' alone (``w = 0``), refined from the pose nearest that plane, and the later
periods keep ``w = 0`` (warm-started, so a step does not pay the 16 starts again). The desired pose ``cMo*``
is found by **virtual visual servoing** from ``s*`` (``v_c = −L_s⁺ (s(cMo) − s*)``): any pose
with the desired features is a goal of the task, so ``bMc* = bMo cMo*⁻¹`` (the joint goal).

The image points of the object (projected ``points_o``) give the visibility constraint.
Units: metres, radians, normalized image coordinates.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import RedservoError
from redservo.redundancy.predictive_model import Horizon, Prediction, _points_interaction

if TYPE_CHECKING:  # the robots (and scipy through them) are not imported with the laws
    from redservo.features import MomentFeatures
    from redservo.robots.base import Robot

__all__ = ["MomentModel", "estimate_pose", "moment_model", "pose_and_weight"]


def _inverse(T: FloatArray) -> FloatArray:
    """The inverse of a homogeneous transform (4, 4) (``redservo.spatial``, which loads scipy,
    is imported only where a pose is estimated, so that ``import redservo`` stays light)."""
    Rt = T.T[:3, :3]  # computed as redservo.spatial.inverse does, to the last bit
    out = np.eye(4)
    out[:3, :3] = Rt
    out[:3, 3] = -(Rt @ T[:3, 3])
    return out


TOL = 1e-9
"""Residual ``‖s(cMo) − s‖`` below which the pose estimate is accepted."""

PLANE_WEIGHT = 0.1
"""Weight of the measured object plane ``(A, B, C)`` (1/m) against the features in the pose
estimate: the six features alone leave poses that differ by a few degrees of tilt with the
same values (the rotation invariants react to the tilt at second order); the plane tells
them apart, and a plane estimated from a depth policy only pulls along those directions."""


class MomentModel(NamedTuple):
    """The global model of a moment task: the model robot, a private copy of the feature
    (its moment cache is the law's), the target pose ``bMo`` (4, 4), ``C`` (m, 6) or None,
    ``s*`` (6,), and the desired pose ``cMo*`` (4, 4) or None."""

    robot: Robot
    feature: MomentFeatures
    bMo: FloatArray
    C: FloatArray | None
    s_star: FloatArray
    cMo_star: FloatArray | None
    s_now: FloatArray | None = None
    """(2p,) the object's points' normalized image coordinates where the model was built."""
    plane_weight: float = PLANE_WEIGHT
    """The weight of the measured plane in the pose estimate (1/m per normalized unit):
    :data:`PLANE_WEIGHT`, or 0 when the plane is a depth policy (module docstring)."""

    def predict(self, q0: FloatArray, U: FloatArray, hz: Horizon, dt: float) -> Prediction | None:
        """The predictions at ``U`` (Nc, n) from ``q0`` (None: a point at or behind the
        camera along the horizon, or a degenerate image)."""
        N, n = hz.N, q0.shape[0]
        P = self.feature.points_o
        m = 6 if self.C is None else self.C.shape[0]
        e, G = np.empty((N, m)), np.empty((N, m, n))
        s, S = np.empty((N, 2 * len(P))), np.empty((N, 2 * len(P), n))
        for k in range(1, N + 1):
            bMc, J = self.robot.kinematics(q0 + dt * (hz.M[k - 1] @ U), check_limits=False)
            cMo = _inverse(bMc) @ self.bMo
            Pc = P @ cMo[:3, :3].T + cMo[:3, 3]
            if not np.all(Pc[:, 2] > 1e-6) or not np.all(np.isfinite(J)):
                return None
            try:
                meas = self.feature.measure(cMo)
                L = self.feature.interaction(meas.s, meas.inv_depth)
            except RedservoError:
                return None
            ek, Gk = self.feature.error(meas.s, self.s_star), L @ J
            e[k - 1], G[k - 1] = (ek, Gk) if self.C is None else (self.C @ ek, self.C @ Gk)
            iz = 1.0 / Pc[:, 2]
            xy = Pc[:, :2] * iz[:, None]
            s[k - 1], S[k - 1] = xy.reshape(-1), _points_interaction(xy, iz) @ J
        return Prediction(e, G, s, S)

    def camera_goal(self, bMc: FloatArray) -> FloatArray | None:
        """``bMc* = bMo cMo*⁻¹`` (None when ``cMo*`` was not found)."""
        return None if self.cMo_star is None else self.bMo @ _inverse(self.cMo_star)


def _vvs(
    feature: Any, cMo: FloatArray, target: FloatArray, iterations: int
) -> tuple[FloatArray, float]:
    """Virtual visual servoing of ``cMo`` towards the features ``target`` (module
    docstring): ``(cMo, residual)``, residual ``inf`` when the pose became degenerate."""
    from redservo.spatial import exp_twist

    T = np.array(cMo, dtype=float)
    r = np.inf
    for _ in range(iterations):
        try:
            meas = feature.measure(T)
            e = feature.error(meas.s, target)
            r = float(np.linalg.norm(e))
            if r < TOL or not np.isfinite(r):
                return T, r
            L = feature.interaction(meas.s, meas.inv_depth)
        except RedservoError:
            return T, np.inf
        v = -np.linalg.lstsq(L, e, rcond=None)[0]
        size = max(float(np.linalg.norm(v[:3])) / 0.1, float(np.linalg.norm(v[3:])) / 0.3, 1.0)
        T = _inverse(exp_twist(v / size)) @ T
    return T, r


def _candidates(feature: Any, s: FloatArray, plane: FloatArray) -> list[FloatArray]:
    """Initial poses ``cMo`` from the measured plane ``(A, B, C)`` and centroid: the object
    plane on the measured one, its centroid on the centroid ray, 8 turns about the normal,
    each seen from both sides."""
    from redservo.spatial import rotvec_to_matrix

    P = feature.points_o
    o = P.mean(axis=0)
    n_o = np.linalg.svd(P - o)[2][2]
    n_c = plane / np.linalg.norm(plane)
    xg, yg = s[0] / s[2], s[1] / s[2]
    Zg = 1.0 / float(plane @ [xg, yg, 1.0])
    out = []
    for sign in (1.0, -1.0):
        R0 = _align(sign * n_o, n_c)
        for k in range(8):
            R = R0 @ rotvec_to_matrix(n_o * (k * np.pi / 4))
            T = np.eye(4)
            T[:3, :3] = R
            T[:3, 3] = Zg * np.array([xg, yg, 1.0]) - R @ o
            out.append(T)
    return out


def _align(a: FloatArray, b: FloatArray) -> FloatArray:
    """The smallest rotation taking the unit vector ``a`` to ``b``."""
    from redservo.spatial import rotvec_to_matrix

    w = np.cross(a, b)
    c = float(a @ b)
    if np.linalg.norm(w) < 1e-12:
        if c > 0:
            return np.eye(3)
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        return rotvec_to_matrix(np.pi * axis / np.linalg.norm(axis))
    return rotvec_to_matrix(w / np.linalg.norm(w) * np.arctan2(np.linalg.norm(w), c))


def _residual(
    feature: Any, T: FloatArray, s: FloatArray, plane: FloatArray, weight: float
) -> FloatArray:
    """``(s(T) − s, w (plane(T) − plane))`` (9,), ``w`` = ``weight``."""
    meas = feature.measure(T)
    return np.concatenate([feature.error(meas.s, s), weight * (meas.inv_depth - plane)])


def _fit(
    feature: Any,
    T: FloatArray,
    s: FloatArray,
    plane: FloatArray,
    iterations: int,
    weight: float,
) -> tuple[FloatArray, float]:
    """Gauss-Newton on :func:`_residual` (plane weight ``weight``) over the pose (forward
    differences of 1e-7 on the camera twist): ``(cMo, ‖s(cMo) − s‖)``, ``inf`` when the pose
    became degenerate."""
    from redservo.spatial import exp_twist

    T = np.array(T, dtype=float)
    try:
        for _ in range(iterations):
            r = _residual(feature, T, s, plane, weight)
            if float(np.linalg.norm(r)) < TOL or not np.all(np.isfinite(r)):
                break
            J = np.empty((r.size, 6))
            for j in range(6):
                d = np.zeros(6)
                d[j] = 1e-7
                Td = _inverse(exp_twist(d)) @ T
                J[:, j] = (_residual(feature, Td, s, plane, weight) - r) / 1e-7
            v = -np.linalg.lstsq(J, r, rcond=None)[0]
            size = max(float(np.linalg.norm(v[:3])) / 0.1, float(np.linalg.norm(v[3:])) / 0.3, 1.0)
            T = _inverse(exp_twist(v / size)) @ T
        r6 = float(np.linalg.norm(feature.error(feature.measure(T).s, s)))
    except RedservoError:
        return T, np.inf
    return T, r6 if np.isfinite(r6) else np.inf


def estimate_pose(
    feature: Any, s: FloatArray, plane: FloatArray, guess: FloatArray | None
) -> FloatArray | None:
    """``cMo`` whose features are ``s`` and whose plane is nearest ``plane`` (module
    docstring), or None."""
    return pose_and_weight(feature, s, plane, guess, PLANE_WEIGHT)[0]


def pose_and_weight(
    feature: Any, s: FloatArray, plane: FloatArray, guess: FloatArray | None, weight: float
) -> tuple[FloatArray | None, float]:
    """``(cMo, w)``: :func:`estimate_pose` with the plane weighted by ``weight``, then, when
    no pose has both the features and that plane, by 0 from the pose nearest the plane
    (module docstring); ``w`` the weight of the accepted pose (``(None, weight)``: none)."""
    if not (np.all(np.isfinite(plane)) and np.linalg.norm(plane) > 0 and s[2] > 0):
        return None, weight
    if guess is not None:
        T, r = _fit(feature, guess, s, plane, 6, weight)
        if r < FIT_TOL:
            return T, weight
    best, best_r = None, np.inf
    for T0 in _candidates(feature, s, plane):
        T, r = _fit(feature, T0, s, plane, 30, weight)
        if r < best_r:
            best, best_r = T, r
        if r < FIT_TOL:
            return T, weight
    if best is None or weight == 0.0:
        return None, weight
    T, r = _fit(feature, best, s, plane, 30, 0.0)  # the plane is a depth policy
    return (T, 0.0) if r < FIT_TOL else (None, weight)


FIT_TOL = 1e-7
"""Feature residual ``‖s(cMo) − s‖`` below which a pose estimate is accepted."""


def moment_model(
    robot: Robot,
    feature: Any,
    task: Any,
    state: Any,
    prev: MomentModel | None,
    bMc: FloatArray,
    bMo: FloatArray | None = None,
) -> MomentModel | None:
    """The :class:`MomentModel` of the current measurement, or None (no pose estimate).
    ``prev``: the previous period's model (its ``bMo`` warm-starts the estimate and its
    ``cMo*`` is reused while ``s*`` is the same). ``bMo``: the target's pose (4, 4; base
    frame, m) when known otherwise (a PnP of the tracked dots,
    :mod:`redservo.redundancy.predictive_pnp`): the model takes it instead of its estimate
    from the features and the plane."""
    from redservo.features import MomentFeatures

    own = (
        prev.feature
        if prev is not None
        else MomentFeatures(
            feature.points_o,
            desired_area=feature.desired_area,
            desired_depth=feature.desired_depth,
            rotation_features=feature.rotation_features,
        )
    )
    weight = PLANE_WEIGHT if prev is None else prev.plane_weight
    if bMo is not None:
        cMo: FloatArray | None = _inverse(bMc) @ bMo
    else:
        s = np.asarray(state.s, dtype=float)
        plane = np.asarray(state.inv_depth[0], dtype=float).reshape(-1)
        guess = None if prev is None else _inverse(bMc) @ prev.bMo
        cMo, weight = pose_and_weight(own, s, plane, guess, weight)
    if cMo is None:
        return None
    s_star = np.asarray(task.s_star, dtype=float)
    star = None
    if prev is not None and np.array_equal(prev.s_star, s_star):
        star = prev.cMo_star
    if star is None:
        T, r = _vvs(own, cMo, s_star, 60)
        star = T if r < TOL else None
    C = None if task.C is None else np.asarray(task.C, dtype=float)
    bMo = bMc @ cMo
    back = _inverse(bMc) @ bMo  # the model's own projection at q
    Pc = own.points_o @ back[:3, :3].T + back[:3, 3]
    s_now = (Pc[:, :2] / Pc[:, 2:3]).reshape(-1)
    return MomentModel(robot, own, bMo, C, s_star, star, s_now, weight)
