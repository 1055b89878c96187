"""The sensing half of the compiled campaign loop: target poses, features, ``e1``, ``J1``, feed-forward.

:func:`redservo.campaign.loop_kernel.closed_loop` calls :func:`loop_task` once per
iteration and :func:`known_feedforward` when the run has a known feed-forward term; they
perform the operations of the object path (:class:`redservo.sensors.IdealSensor`,
:meth:`redservo.task.VisualTask.evaluate_measured`, the image check of the simulator,
:func:`redservo.control.feedforward.known_feedforward`) in the same order with the same
kernels, so every number is the object path's to the bit (tests/test_campaign_fast.py).

Packs (built by :mod:`redservo.campaign.fastloop`; O targets, K task terms, M moment terms):

* ``scene = (bMw, wMo (O, 4, 4), vis_pts (O, P, 3), vis_cnt (O,), cam (7,), check,
  moving (O,), times (O, W), w_cnt (O,), w_poses (O, W, 4, 4), w_rot (O, W, 3))``: ``wMo``
  the pose of a static target; a moving one (``moving[o]``) follows the waypoints
  ``times``/``w_poses`` (:class:`redservo.scene.Waypoints`, ``w_rot`` its segments'
  world-frame rotation vectors); ``cam`` = (px, py, u0, v0, width, height, margin) in pixels.
* ``task = (kind (K,), obj (K,), pt (K, 3), aux (K,), m_pts (M, P, 3), m_cnt (M,),
  m_opt (M, 3), s_star (k,), C (m, k), has_C, depth_scale)`` (``C`` a (0, 0) array when
  ``has_C`` is False): term j is an image point
  (``kind`` :data:`POINT`, ``pt[j]`` in the object frame, 2 rows) or the six moment
  features (:data:`MOMENTS`, 6 rows) of the ``m_cnt[aux[j]]`` points ``m_pts[aux[j]]``
  with ``m_opt[aux[j]] = (a*, Z*, rotation-feature kind)`` (:mod:`redservo.kernels.moments`).

Units: m, rad, s; features in normalized image units.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.features import MIN_DEPTH, wrap_angle
from redservo.kernels.moment_interaction import moment_features_interaction
from redservo.kernels.moments import moment_measure
from redservo.kernels.points import camera_point, point_interaction_into

__all__ = [
    "MOMENTS",
    "POINT",
    "all_finite",
    "inverse",
    "known_feedforward",
    "loop_task",
    "target_poses",
]

POINT, MOMENTS = 0, 1
"""Term kinds of the task pack."""


@kernel
def all_finite(J1: Any, e1: Any) -> bool:
    """``np.all(np.isfinite(J1)) and np.all(np.isfinite(e1))`` for ``J1`` (m, n) and ``e1``
    (m,), without the temporary arrays."""
    for i in range(J1.shape[0]):
        for j in range(J1.shape[1]):
            if not math.isfinite(J1[i, j]):
                return False
    for i in range(e1.shape[0]):
        if not math.isfinite(e1[i]):
            return False
    return True


@kernel
def inverse(T: Any) -> Any:
    """:func:`redservo.spatial.inverse` with the same arithmetic (``-(R^T @ t)`` by BLAS)."""
    R = np.ascontiguousarray(T[:3, :3])
    t = np.ascontiguousarray(T[:3, 3])
    out = np.empty((4, 4))
    out[:3, :3] = R.T
    out[:3, 3] = -np.dot(R.T, t)
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0
    return out


@kernel
def in_image(cMo: Any, pts: Any, cam: Any) -> bool:
    """``visible_points`` then ``_in_image`` of the simulator; ``cam`` = (px, py, u0, v0,
    width, height, margin) in pixels."""
    R = np.ascontiguousarray(cMo[:3, :3])
    P = np.dot(pts, R.T)
    for i in range(P.shape[0]):
        for j in range(3):
            P[i, j] = P[i, j] + cMo[j, 3]
    for i in range(P.shape[0]):
        if P[i, 2] <= 1e-9:
            return False
    margin = cam[6]
    for i in range(P.shape[0]):
        u = P[i, 0] / P[i, 2] * cam[0] + cam[2]
        v = P[i, 1] / P[i, 2] * cam[1] + cam[3]
        if not (u >= margin and u <= cam[4] - margin and v >= margin and v <= cam[5] - margin):
            return False
    return True


@kernel
def _rotvec_matrix(r: Any) -> Any:
    """:func:`redservo.spatial.rotvec_to_matrix` with the same arithmetic (Rodrigues)."""
    theta = np.sqrt(np.dot(r, r))
    K = np.zeros((3, 3))
    K[0, 1] = -r[2]
    K[0, 2] = r[1]
    K[1, 0] = r[2]
    K[1, 2] = -r[0]
    K[2, 0] = -r[1]
    K[2, 1] = r[0]
    KK = np.dot(K, K)
    out = np.eye(3)
    if theta < 1e-8:
        for i in range(3):
            for j in range(3):
                out[i, j] = (out[i, j] + K[i, j]) + 0.5 * KK[i, j]
        return out
    a = np.sin(theta) / theta
    # Python's ``theta**2`` is libm's pow(theta, 2.0), which may differ from theta*theta by
    # an ulp; LLVM turns a pow by the constant 2.0 into a product, so the exponent is made
    # opaque (2.0 + 0.0*theta is 2.0 for any finite theta but cannot be folded).
    two = 2.0 + 0.0 * theta
    b = (1.0 - np.cos(theta)) / theta**two
    for i in range(3):
        for j in range(3):
            out[i, j] = (out[i, j] + a * K[i, j]) + b * KK[i, j]
    return out


@kernel
def _waypoint_pose(times: Any, poses: Any, rot: Any, count: int, t: float) -> Any:
    """:meth:`redservo.scene.Waypoints.pose` at ``t`` (s): ``wMo`` (4x4)."""
    if t < times[0] or t >= times[count - 1]:
        return poses[0].copy() if t < times[0] else poses[count - 1].copy()
    k = 0
    while k + 1 < count and times[k + 1] <= t:  # searchsorted(side="right") - 1
        k += 1
    tau = (t - times[k]) / (times[k + 1] - times[k])
    r = np.empty(3)
    for i in range(3):
        r[i] = tau * rot[k, i]
    T = np.eye(4)
    T[:3, :3] = np.dot(_rotvec_matrix(r), np.ascontiguousarray(poses[k, :3, :3]))
    for i in range(3):
        T[i, 3] = (1.0 - tau) * poses[k, i, 3] + tau * poses[k + 1, i, 3]
    return T


@kernel
def target_poses(cMw: Any, scene: Any, t: float) -> Any:
    """``cMo`` (O, 4, 4) of every target at time ``t`` (s): :meth:`redservo.scene.Scene.cMo`."""
    _, wMo, _, _, _, _, moving, times, w_cnt, w_poses, w_rot = scene
    n_obj = wMo.shape[0]
    cMo = np.empty((n_obj, 4, 4))
    for o in range(n_obj):
        if moving[o]:
            pose = _waypoint_pose(times[o], w_poses[o], w_rot[o], w_cnt[o], t)
        else:
            pose = np.ascontiguousarray(wMo[o])
        cMo[o] = np.dot(cMw, pose)
    return cMo


@kernel
def _point_rows(cMo: Any, pt: Any, j: int, row: int, s: Any, L: Any, depth_scale: float) -> bool:
    """Point term ``j``: its ``s`` (2 rows from ``row``) and ``L`` (current depth); False when
    the point is at or behind the camera."""
    X, Y, Z = camera_point(cMo, pt, j)  # points_measure's arithmetic, no temporaries
    if Z <= MIN_DEPTH:
        return False
    x, y, iz = X / Z, Y / Z, 1.0 / Z
    s[row] = x
    s[row + 1] = y
    d = iz if depth_scale == 1.0 else iz / depth_scale
    point_interaction_into(x, y, d, L, row)
    return True


@kernel
def _moment_rows(cMo: Any, task: Any, a: int, row: int, s: Any, L: Any) -> bool:
    """Moment term (index ``a`` of the moment arrays): its six ``s`` and ``L`` rows; False
    when the features are invalid (the object path's GeometryError: target lost)."""
    _, _, _, _, m_pts, m_cnt, m_opt, _, _, _, depth_scale = task
    pts = np.ascontiguousarray(m_pts[a, : m_cnt[a]])
    area, depth, kind = m_opt[a, 0], m_opt[a, 1], int(m_opt[a, 2])
    sm, plane, xg, yg, mu, code, _ = moment_measure(pts, cMo, area, depth, kind)
    if code != 0:
        return False
    d = plane if depth_scale == 1.0 else plane / depth_scale
    L[row : row + 6] = moment_features_interaction(pts.shape[0], xg, yg, mu, d, area, depth, kind)
    s[row : row + 6] = sm
    return True


@kernel
def measure(cMo: Any, task: Any) -> Any:
    """``(s, L, ok)`` of every term at the targets' poses ``cMo`` (the ideal sensor and the
    task's interaction matrix, current depth)."""
    kind, obj, pt, aux, _, _, _, s_star, _, _, depth_scale = task
    k = s_star.shape[0]
    s = np.empty(k)
    L = np.empty((k, 6))
    row = 0
    for j in range(kind.shape[0]):
        if kind[j] == POINT:
            ok = _point_rows(cMo[obj[j]], pt, j, row, s, L, depth_scale)
            row += 2
        else:
            ok = _moment_rows(cMo[obj[j]], task, aux[j], row, s, L)
            row += 6
        if not ok:
            return s, L, False
    return s, L, True


@kernel
def error(s: Any, task: Any) -> Any:
    """``s - s*`` (k,), the moment orientation α wrapped to (-π/2, π/2] (period π)."""
    kind, _, _, _, _, _, _, s_star, _, _, _ = task
    e = s - s_star
    row = 0
    for j in range(kind.shape[0]):
        if kind[j] == POINT:
            row += 2
        else:
            e[row + 3] = 0.5 * wrap_angle(2.0 * e[row + 3])
            row += 6
    return e


@kernel
def loop_task(bMc: Any, scene: Any, task: Any, t: float) -> Any:
    """``(e, L, cMw, lost)`` at the camera pose ``bMc`` and time ``t`` (s): the targets'
    poses, the features ``s``, the error ``e = s − s*`` (k,) and the interaction matrix
    ``L`` (k, 6), and the image check; ``e1`` and ``J1`` are the step kernel's
    (:func:`redservo.kernels.control.task_rows`)."""
    bMw, _, vis_pts, vis_cnt, cam, check = (
        scene[0],
        scene[1],
        scene[2],
        scene[3],
        scene[4],
        scene[5],
    )
    cMw = np.dot(inverse(bMc), bMw)
    cMo = target_poses(cMw, scene, t)
    s, L, ok = measure(cMo, task)
    if not ok:
        return s, L, cMw, True
    e = error(s, task)
    if check:
        for o in range(cMo.shape[0]):
            if not in_image(cMo[o], np.ascontiguousarray(vis_pts[o, : vis_cnt[o]]), cam):
                return e, L, cMw, True
    return e, L, cMw, False


@kernel
def known_feedforward(cMw: Any, scene: Any, task: Any, t: float, dt: float) -> Any:
    """``(∂e1/∂t, ok)``: :func:`redservo.control.feedforward.known_feedforward`, the central
    difference of the error over ``[t - dt/2, t + dt/2]`` (clipped at 0) with the camera
    frozen at ``cMw``; ``ok`` False where the object path raises (a feature invalid)."""
    C, has_C = task[8], task[9]
    h = 0.5 * dt
    t_m = t - h
    if not t_m > 0.0:  # max(t - h, 0.0)
        t_m = t_m if t_m == 0.0 else 0.0
    s_p, _, ok_p = measure(target_poses(cMw, scene, t + h), task)
    s_m, _, ok_m = measure(target_poses(cMw, scene, t_m), task)
    ds = error(s_p, task) - error(s_m, task)
    ds = ds / (h + (h if h <= t else t))
    if has_C:
        ds = np.dot(C, ds)
    return ds, ok_p and ok_m
