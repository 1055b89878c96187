"""Is a campaign sample's goal reachable? Inverse kinematics of the desired camera pose.

A sample is *reachable* when some joint configuration within the margin either puts the
camera at the task's desired pose, or (features that several poses share, such as moments)
brings the task error itself below half the convergence tolerance (the same projected
damped least squares on ``e1(q)``, from the non-random seeds below). The pose is
``bMc* = wMb⁻¹ wMref(0) cdMref⁻¹``, the scenario's ``task.desired_pose`` relative to the
first feature's object; every joint stays at least ``margin`` (a fraction of its range,
default the scenario's success margin ``min_margin``) inside its limits. The search is a
damped least-squares inverse kinematics projected on those bounds, from several seeds: the
sample's start, the scenario's nominal start, the middle of the range, four starts around
the sample's start (normal, 15 % of each range) and :data:`RANDOM_SEEDS` configurations drawn
uniformly inside the bounds (a generator seeded with 0: the answer depends only on the
sample). It uses the robot's own kinematics
(``Robot.kinematics``: the camera pose and its Jacobian in the camera frame).

A reachable goal is not a promise that a method can get there (the path matters); an
unreachable one is a goal no method can reach within the success margin, so that the
campaign tables report the success rate among the reachable samples too.
Units: metres, radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.spatial import inverse, matrix_to_rotvec

__all__ = ["RANDOM_SEEDS", "desired_camera_pose", "reachable", "reachable_column", "solve_ik"]

RANDOM_SEEDS = 12
"""Random seeds tried after the deterministic ones."""
POS_TOL = 1e-4
"""Position tolerance of the inverse kinematics (m)."""
ROT_TOL = 1e-3
"""Orientation tolerance (rad)."""
STALL_ITERATIONS, STALL_GAIN = 40, 0.99
"""A seed is given up when its pose error has not fallen below 0.99 of its best for 40
iterations (stuck against the bounds or in a local minimum)."""


def desired_camera_pose(exp: Any) -> FloatArray | None:
    """``bMc*`` (4, 4) of an :class:`~redservo.experiment.Experiment`, or None when its task
    gives desired feature values rather than a desired pose."""
    spec = exp.scenario.spec
    pose = spec.task.desired_pose
    if pose is None:
        return None
    ref = spec.features[0].object
    wMref = exp.scene.wMo(ref, 0.0)
    return np.asarray(inverse(exp.scene.wMb) @ wMref @ inverse(pose.matrix()))


def _pose_error(bMc: FloatArray, target: FloatArray) -> FloatArray:
    """(6,) camera-frame twist ``(t, θu)`` from ``bMc`` to ``target`` (m, rad)."""
    cMt = inverse(bMc) @ target
    return np.concatenate([cMt[:3, 3], _theta_u(cMt[:3, :3])])


def _theta_u(R: FloatArray) -> FloatArray:
    """θu of a rotation matrix (rad): ``θ/(2 sin θ) vee(R − Rᵀ)`` away from θ = π (where
    :func:`redservo.spatial.matrix_to_rotvec` takes over), 20x cheaper than it."""
    c = min(1.0, max(-1.0, 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)))
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    theta = math.acos(c)
    if theta < 1e-6:
        return 0.5 * v
    if theta > math.pi - 1e-3:
        return np.asarray(matrix_to_rotvec(R))
    return (0.5 * theta / math.sin(theta)) * v


def _dls(J: FloatArray, err: FloatArray, damping: float) -> FloatArray:
    """Damped least-squares step ``Jᵀ(JJᵀ + δ²I)⁻¹ err`` (least squares if that is singular,
    e.g. ``J`` overflowed near a singular pose: then NaN, and the seed is given up)."""
    A = J @ J.T + damping**2 * np.eye(J.shape[0])
    try:
        return np.asarray(J.T @ np.linalg.solve(A, err))
    except np.linalg.LinAlgError:
        return np.full(J.shape[1], np.nan)


def solve_ik(
    robot: Any,
    target: FloatArray,
    seed: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    *,
    iterations: int = 300,
    damping: float = 1e-3,
) -> FloatArray | None:
    """Projected damped least squares from ``seed``: ``q ← clip(q + Jᵀ(JJᵀ + δ²I)⁻¹ err)``,
    the joints at a bound that the step pushes out left out of ``J`` (active set);
    returns ``q`` within ``[lo, hi]`` reaching ``target`` within :data:`POS_TOL` and
    :data:`ROT_TOL`, or None (also when the error stalls: :data:`STALL_ITERATIONS`)."""
    q = np.clip(np.asarray(seed, dtype=float), lo, hi)
    best, since = math.inf, 0
    for _ in range(iterations):
        bMc, J = robot.kinematics(q, check_limits=False)
        err = _pose_error(bMc, target)
        if np.linalg.norm(err[:3]) < POS_TOL and np.linalg.norm(err[3:]) < ROT_TOL:
            return q
        size = float(np.linalg.norm(err))
        if size < STALL_GAIN * best:
            best, since = size, 0
        else:
            since += 1
            if since >= STALL_ITERATIONS:  # stuck against the bounds or in a local minimum
                return None
        step = _dls(J, err, damping)
        blocked = ((q <= lo) & (step < 0)) | ((q >= hi) & (step > 0))
        if blocked.any():  # joints at a bound pushing out: solve with the others
            step = _dls(np.where(blocked, 0.0, J), err, damping)
        if not np.all(np.isfinite(step)):
            return None
        size = float(np.max(np.abs(step)))
        if size > 0.5:  # at most 0.5 rad (or m) per joint and iteration
            step *= 0.5 / size
        q = np.clip(q + step, lo, hi)
    return None


def reachable(exp: Any, *, margin: float | None = None, nominal: Any = None) -> bool | None:
    """Whether the sample's desired camera pose is reachable with every joint at least
    ``margin`` of its range inside its limits (module docstring); None when the task has no
    desired pose. ``nominal``: the scenario's nominal start, one more seed."""
    target = desired_camera_pose(exp)
    if target is None:
        return None
    lim = exp.limits
    m = exp.options.min_margin if margin is None else margin
    rng = lim.q_max - lim.q_min
    lo, hi = lim.q_min + m * rng, lim.q_max - m * rng
    gen = np.random.default_rng(0)
    seeds = [np.asarray(exp.q0, dtype=float)]
    if nominal is not None:
        seeds.append(np.asarray(nominal, dtype=float))
    seeds.append(0.5 * (lo + hi))
    seeds += [np.clip(seeds[0] + gen.normal(0.0, 0.15, rng.shape) * rng, lo, hi) for _ in range(4)]
    near = list(seeds)  # the start, the nominal start, the middle, 4 around the start
    seeds += [gen.uniform(lo, hi) for _ in range(RANDOM_SEEDS)]
    if any(solve_ik(exp.robot, target, s, lo, hi) is not None for s in seeds):
        return True
    tol = 0.5 * exp.options.tolerance
    return any(_feature_goal(exp, s, lo, hi, tol) for s in near)


def _feature_goal(exp: Any, seed: FloatArray, lo: FloatArray, hi: FloatArray, tol: float) -> bool:
    """Projected damped least squares on the task error ``e1(q)`` itself (the scene at t = 0):
    True if some ``q`` within ``[lo, hi]`` reaches ``‖e1‖ < tol``."""
    from redservo.errors import GeometryError

    q = np.clip(np.asarray(seed, dtype=float), lo, hi)
    for _ in range(150):
        bMc, J = exp.robot.kinematics(q, check_limits=False)
        try:
            st = exp.task.evaluate(exp.scene, bMc, J, 0.0)
        except GeometryError:
            return False
        if float(np.linalg.norm(st.e1)) < tol:
            return True
        if not np.all(np.isfinite(st.J1)):
            return False
        step = -_dls(st.J1, st.e1, 1e-3)
        blocked = ((q <= lo) & (step < 0)) | ((q >= hi) & (step > 0))
        if blocked.any():
            step = -_dls(np.where(blocked, 0.0, st.J1), st.e1, 1e-3)
        if not np.all(np.isfinite(step)):
            return False
        size = float(np.max(np.abs(step)))
        if size > 0.3:
            step *= 0.3 / size
        q = np.clip(q + step, lo, hi)
    return False


def reachable_column(values: Sequence[str]) -> np.ndarray | None:
    """The ``reachable`` column of ``samples.csv`` as booleans, or None when no row knows it
    (every value empty)."""
    if not any(values):
        return None
    return np.array([v == "True" for v in values], dtype=bool)
