"""Inverse kinematics of a camera pose: projected damped least squares within joint bounds.

Used by the campaigns' reachability test (:mod:`redservo.campaign.reach`) and by the
``predictive`` law's joint-goal search (:mod:`redservo.redundancy.predictive_goal`). It uses
the robot's own kinematics (``Robot.kinematics``: the camera pose ``bMc`` and its Jacobian in
the camera frame, ``v_c = J q̇``). Units: metres, radians.
"""

from __future__ import annotations

import math
from collections.abc import Generator
from typing import Any, cast

import numpy as np

from redservo._validation import FloatArray
from redservo.spatial import inverse, matrix_to_rotvec

__all__ = [
    "POS_TOL",
    "ROT_TOL",
    "Stall",
    "ik_steps",
    "pose_error",
    "projected_step",
    "solve_ik",
]

POS_TOL = 1e-4
"""Position tolerance of the inverse kinematics (m)."""
ROT_TOL = 1e-3
"""Orientation tolerance (rad)."""
STALL_ITERATIONS, STALL_GAIN = 40, 0.99
"""A seed is given up when its pose error has not fallen below 0.99 of its best for 40
iterations (stuck against the bounds or in a local minimum)."""


def pose_error(bMc: FloatArray, target: FloatArray) -> FloatArray:
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


class Stall:
    """Call with each iteration's error: True once it has not fallen below
    :data:`STALL_GAIN` of its best for ``iterations`` (:data:`STALL_ITERATIONS`) iterations;
    ``since == 0`` right after a call that set a new best."""

    def __init__(self, iterations: int = STALL_ITERATIONS) -> None:
        self.iterations = iterations
        self.best, self.since = math.inf, 0

    def __call__(self, size: float) -> bool:
        if size < STALL_GAIN * self.best:
            self.best, self.since = size, 0
            return False
        self.since += 1
        return self.since >= self.iterations


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
    :data:`ROT_TOL`, or None (also when the error stalls: :data:`STALL_ITERATIONS`):
    :func:`ik_steps` run to its end."""
    steps = ik_steps(robot, target, seed, lo, hi, iterations=iterations, damping=damping)
    while True:
        try:
            next(steps)
        except StopIteration as stop:
            return cast("FloatArray | None", stop.value)


def ik_steps(
    robot: Any,
    target: FloatArray,
    seed: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    *,
    iterations: int = 300,
    damping: float = 1e-3,
) -> Generator[None, None, FloatArray | None]:
    """:func:`solve_ik` one iteration (one kinematics evaluation, one step) per ``yield``,
    so that a caller can spread it over several periods; its return value is the result."""
    q = np.clip(np.asarray(seed, dtype=float), lo, hi)
    stalled = Stall()
    for _ in range(iterations):
        bMc, J = robot.kinematics(q, check_limits=False)
        err = pose_error(bMc, target)
        if np.linalg.norm(err[:3]) < POS_TOL and np.linalg.norm(err[3:]) < ROT_TOL:
            return q
        if stalled(float(np.linalg.norm(err))):  # stuck against the bounds or a local minimum
            return None
        nxt = projected_step(J, err, q, lo, hi, damping, 0.5)  # at most 0.5 rad (or m)
        if nxt is None:
            return None
        q = nxt
        yield
    return None


def projected_step(
    J: FloatArray,
    err: FloatArray,
    q: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    damping: float,
    cap: float,
) -> FloatArray | None:
    """One projected damped-least-squares step: ``clip(q + Jᵀ(JJᵀ + δ²I)⁻¹ err, lo, hi)``,
    the joints at a bound that the step pushes out left out of ``J`` (active set), the step
    scaled to at most ``cap`` per joint (rad or m); None when it is not finite (``J``
    singular or overflowed). ``err`` is the change asked of the task (``−e`` to cancel an
    error ``e``)."""
    step = _dls(J, err, damping)
    blocked = ((q <= lo) & (step < 0)) | ((q >= hi) & (step > 0))
    if blocked.any():  # joints at a bound pushing out: solve with the others
        step = _dls(np.where(blocked, 0.0, J), err, damping)
    if not np.all(np.isfinite(step)):
        return None
    size = float(np.max(np.abs(step)))
    if size > cap:
        step *= cap / size
    return np.asarray(np.clip(q + step, lo, hi))
