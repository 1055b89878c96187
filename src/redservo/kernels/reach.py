"""Reachability search kernels: the projected damped least squares of :mod:`redservo.robots.ik`, compiled.

:func:`pose_search` and :func:`feature_search` run, over a batch of seeds, the searches of
:mod:`redservo.campaign.reach` (the camera pose by :func:`redservo.robots.ik.solve_ik`, the task
error by the feature search) with the same steps, tolerances, step caps and stall rule, in
one call without Python in the loop and without BLAS (every product and the small linear
solve are loops: no BLAS thread is ever started here). Arithmetic differs from numpy's in the
last bits only (another summation order, Gaussian elimination instead of LAPACK's ``gesv``):
the verdicts are the same (tests/test_reach_compiled.py, 200 samples of each shipped
campaign against the verdicts of the Python search).

Packs: ``robot`` is :func:`redservo.campaign.looppack.robot_args`; ``scene`` and ``task``
are :func:`~redservo.campaign.looppack.scene_args` (with the image check off) and
:func:`~redservo.campaign.looppack.task_args`. Units: metres, radians.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.control import task_rows
from redservo.kernels.kinematics import matmul
from redservo.kernels.loop_task import inverse, loop_task
from redservo.kernels.robot import robot_kinematics

__all__ = [
    "feature_search",
    "feature_solution",
    "pose_search",
    "pose_solution",
    "projected_step",
    "theta_u",
]

POS_TOL, ROT_TOL = 1e-4, 1e-3
""":data:`redservo.robots.ik.POS_TOL` (m) and :data:`redservo.robots.ik.ROT_TOL` (rad)."""
STALL_ITERATIONS, STALL_GAIN = 40, 0.99
""":data:`redservo.robots.ik.STALL_ITERATIONS` and :data:`redservo.robots.ik.STALL_GAIN`."""


@kernel
def theta_u(R: Any) -> Any:
    """θu (3,) of a rotation matrix (rad): :func:`redservo.robots.ik._theta_u`; near θ = π from the
    largest diagonal term (the axis up to sign, which θ = π makes irrelevant)."""
    c = min(1.0, max(-1.0, 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)))
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    theta = math.acos(c)
    if theta < 1e-6:
        return 0.5 * v
    if theta <= math.pi - 1e-3:
        return (0.5 * theta / math.sin(theta)) * v
    i = 0
    for k in range(1, 3):
        if R[k, k] > R[i, i]:
            i = k
    u = np.empty(3)  # (1 - cos θ) u_i u: the symmetric part of R less cos θ I, row i
    for k in range(3):
        u[k] = 0.5 * (R[i, k] + R[k, i])
    u[i] = R[i, i] - c
    if u[0] * v[0] + u[1] * v[1] + u[2] * v[2] < 0.0:  # the sign of v = 2 sin θ u
        u = -u
    return theta * u / math.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2)


@kernel
def _solve(A: Any, b: Any) -> Any:
    """``A⁻¹ b`` by Gaussian elimination with partial pivoting; NaN when ``A`` is singular."""
    n = b.shape[0]
    M, x = A.copy(), b.copy()
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(M[i, k]) > abs(M[p, k]):
                p = i
        if not M[p, k] != 0.0:  # zero or NaN pivot
            return np.full(n, np.nan)
        for j in range(n):
            M[k, j], M[p, j] = M[p, j], M[k, j]
        x[k], x[p] = x[p], x[k]
        for i in range(k + 1, n):
            f = M[i, k] / M[k, k]
            for j in range(k, n):
                M[i, j] -= f * M[k, j]
            x[i] -= f * x[k]
    for k in range(n - 1, -1, -1):
        acc = x[k]
        for j in range(k + 1, n):
            acc -= M[k, j] * x[j]
        x[k] = acc / M[k, k]
    return x


@kernel
def _dls(J: Any, err: Any, damping: float) -> Any:
    """``Jᵀ(JJᵀ + δ²I)⁻¹ err`` (:func:`redservo.robots.ik._dls`)."""
    A = matmul(J, np.ascontiguousarray(J.T))
    for i in range(A.shape[0]):
        A[i, i] += damping * damping
    y = _solve(A, err)
    return matmul(np.ascontiguousarray(J.T), y.reshape((-1, 1)))[:, 0]


@kernel
def projected_step(J: Any, err: Any, q: Any, lo: Any, hi: Any, damping: float, cap: float) -> Any:
    """``(q_next, ok)``: :func:`redservo.robots.ik.projected_step` (``ok`` False where it returns None)."""
    step = _dls(J, err, damping)
    blocked = ((q <= lo) & (step < 0)) | ((q >= hi) & (step > 0))
    if blocked.any():
        Jb = J.copy()
        for j in range(q.shape[0]):
            if blocked[j]:
                Jb[:, j] = 0.0
        step = _dls(Jb, err, damping)
    if not np.all(np.isfinite(step)):
        return q, False
    size = np.max(np.abs(step))
    if size > cap:
        step *= cap / size
    return np.minimum(np.maximum(q + step, lo), hi), True


@kernel
def _pose_seed(
    robot: Any, target: Any, seed: Any, lo: Any, hi: Any, iterations: int, damping: float
) -> bool:
    """:func:`redservo.robots.ik.solve_ik` from one seed: True when it reaches ``target``."""
    return pose_solution(robot, target, seed, lo, hi, iterations, damping)[0]


@kernel
def pose_solution(
    robot: Any, target: Any, seed: Any, lo: Any, hi: Any, iterations: int, damping: float
) -> Any:
    """``(reached, q)``: :func:`redservo.robots.ik.solve_ik` from one seed and where it ends."""
    q = np.minimum(np.maximum(seed.copy(), lo), hi)
    best, since = np.inf, 0
    for _ in range(iterations):
        bMc, J = robot_kinematics(q, robot)
        cMt = matmul(inverse(bMc), target)
        err = np.empty(6)
        err[:3] = cMt[:3, 3]
        err[3:] = theta_u(np.ascontiguousarray(cMt[:3, :3]))
        if np.linalg.norm(err[:3]) < POS_TOL and np.linalg.norm(err[3:]) < ROT_TOL:
            return True, q
        size = float(np.linalg.norm(err))
        if size < STALL_GAIN * best:
            best, since = size, 0
        else:
            since += 1
            if since >= STALL_ITERATIONS:
                return False, q
        q, ok = projected_step(J, err, q, lo, hi, damping, 0.5)
        if not ok:
            return False, q
    return False, q


@kernel
def pose_search(robot: Any, target: Any, seeds: Any, lo: Any, hi: Any) -> int:
    """The first seed (row of ``seeds``) from which the camera reaches ``target`` (``bMc*``,
    4x4) within ``[lo, hi]``, or -1 (:func:`redservo.robots.ik.solve_ik`'s defaults: 300
    iterations, damping 1e-3)."""
    for s in range(seeds.shape[0]):
        if _pose_seed(robot, target, seeds[s], lo, hi, 300, 1e-3):
            return s
    return -1


@kernel
def _feature_seed(
    robot: Any, scene: Any, task: Any, seed: Any, lo: Any, hi: Any, tol: float
) -> bool:
    """The feature search of :mod:`redservo.campaign.reach` from one seed."""
    return feature_solution(robot, scene, task, seed, lo, hi, tol)[0]


@kernel
def feature_solution(
    robot: Any, scene: Any, task: Any, seed: Any, lo: Any, hi: Any, tol: float
) -> Any:
    """``(reached, q)``: the feature search of :mod:`redservo.campaign.reach` from one seed
    (:func:`redservo.campaign.reach.feature_solution`) and where it ends (rad or m)."""
    q = np.minimum(np.maximum(seed.copy(), lo), hi)
    best, since = np.inf, 0
    for _ in range(150):
        bMc, J = robot_kinematics(q, robot)
        e, L, _, lost = loop_task(bMc, scene, task, 0.0)
        if lost:  # a feature cannot be measured (GeometryError on the object path)
            return False, q
        e1, J1 = task_rows(e, L, task[8], J)  # CM01 eq. 25, the step kernel's
        size = float(np.linalg.norm(e1))
        if size < tol:
            return True, q
        if size < STALL_GAIN * best:
            best, since = size, 0
        else:
            since += 1
            if since >= STALL_ITERATIONS:
                return False, q
        if not np.all(np.isfinite(J1)):
            return False, q
        q, ok = projected_step(np.ascontiguousarray(J1), -e1, q, lo, hi, 1e-3, 0.3)
        if not ok:
            return False, q
    return False, q


@kernel
def feature_search(
    robot: Any, scene: Any, task: Any, seeds: Any, lo: Any, hi: Any, tol: float
) -> int:
    """The first seed from which ``‖e1(q)‖ < tol`` within ``[lo, hi]`` (the scene at
    t = 0), or -1."""
    for s in range(seeds.shape[0]):
        if _feature_seed(robot, scene, task, seeds[s], lo, hi, tol):
            return s
    return -1
