"""Is a campaign sample's goal reachable? Inverse kinematics of the desired camera pose.

A sample is *reachable* when some joint configuration within the margin either puts the
camera at the task's desired pose, or (features that several poses share, such as moments)
brings the task error itself below half the convergence tolerance (the same projected
damped least squares on ``e1(q)``, from the same seeds). The pose is
``bMc* = wMb⁻¹ wMref(0) cdMref⁻¹``, the scenario's ``task.desired_pose`` relative to the
first feature's object; every joint stays at least ``margin`` (a fraction of its range,
default the scenario's success margin ``min_margin``) inside its limits. The search is a
damped least-squares inverse kinematics projected on those bounds, from several seeds: the
sample's start, the scenario's nominal start, the middle of the range, four starts around
the sample's start (normal, 15 % of each range) and :data:`RANDOM_SEEDS` configurations drawn
uniformly inside the bounds (a generator seeded with 0: the answer depends only on the
sample). It uses the robot's own kinematics
(``Robot.kinematics``: the camera pose and its Jacobian in the camera frame).

The search runs compiled, every seed in one kernel call (:mod:`redservo.kernels.reach`),
for the robots the compiled campaign loop covers (the Afma6, DH and URDF chains); the
feature stage too when that loop can measure the task. Other robots and tasks run the same
search in Python (:func:`redservo.robots.ik.solve_ik`). Both give the same verdicts on the first
200 samples of every shipped campaign (tests/test_reach_compiled.py).

A reachable goal is not a promise that a method can get there (the path matters); an
unreachable one is a goal this search did not find within the success margin (a search can
miss one: the campaign report counts the successes on samples called unreachable, and with
:data:`RANDOM_SEEDS` = 60 there was none on the shipped campaigns, docs/results.md), so that
the campaign tables report the success rate among the reachable samples too. With
obstacles, the goal configuration must also be clear of them by ``d_safe``
(:mod:`redservo.campaign.reach_obstacles`). Units: metres, radians.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.campaign.reach_obstacles import clear_search, goal_clearance
from redservo.robots.ik import Stall, projected_step, solve_ik
from redservo.spatial import inverse

__all__ = [
    "RANDOM_SEEDS",
    "compile_search",
    "desired_camera_pose",
    "feature_solution",
    "reachable",
    "reachable_column",
    "solve_ik",
]

RANDOM_SEEDS = 60
"""Random seeds tried after the deterministic ones."""


def desired_camera_pose(exp: Any) -> FloatArray | None:
    """``bMc*`` (4, 4) of an :class:`~redservo.experiment.build.Experiment`, or None when its task
    gives desired feature values rather than a desired pose."""
    spec = exp.scenario.spec
    pose = spec.task.desired_pose
    if pose is None:
        return None
    ref = spec.features[0].object
    wMref = exp.scene.wMo(ref, 0.0)
    return np.asarray(inverse(exp.scene.wMb) @ wMref @ inverse(pose.matrix()))


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
    seeds += [gen.uniform(lo, hi) for _ in range(RANDOM_SEEDS)]
    tol = 0.5 * exp.options.tolerance
    clear = goal_clearance(exp)  # obstacles: the goal configuration clear by d_safe
    if clear is not None:
        return clear_search(exp, target, seeds, lo, hi, tol, clear, feature_solution)
    compiled = _compiled_search(exp, target, np.array(seeds), lo, hi, tol)
    if compiled is not None:
        return compiled
    if any(solve_ik(exp.robot, target, s, lo, hi) is not None for s in seeds):
        return True
    return any(feature_solution(exp, s, lo, hi, tol) is not None for s in seeds)


def _compiled_search(
    exp: Any, target: FloatArray, seeds: FloatArray, lo: FloatArray, hi: FloatArray, tol: float
) -> bool | None:
    """The same search in one kernel call per stage (:mod:`redservo.kernels.reach`), or None
    when the robot has no compiled kinematics (the search then runs in Python). The feature
    stage runs in Python when the compiled loop cannot measure the task."""
    from redservo.campaign.looppack import (
        robot_args,
        robot_reason,
        scene_reason,
        search_scene_args,
        task_args,
    )
    from redservo.kernels.blas import one_blas_thread
    from redservo.kernels.reach import feature_search, pose_search

    if robot_reason(exp) is not None:
        return None
    robot, c = robot_args(exp), np.ascontiguousarray
    seeds, lo, hi = c(seeds, dtype=np.float64), c(lo, dtype=np.float64), c(hi, dtype=np.float64)
    with one_blas_thread():
        if pose_search(robot, c(target, dtype=np.float64), seeds, lo, hi) >= 0:
            return True
        if scene_reason(exp) is not None:
            return any(feature_solution(exp, s, lo, hi, tol) is not None for s in seeds)
        scene = search_scene_args(exp)
        return bool(feature_search(robot, scene, task_args(exp), seeds, lo, hi, tol) >= 0)


def compile_search(exp: Any) -> None:
    """Compile (or load from the disk cache) the kernels of the search for ``exp``'s robot
    and task (``redservo warmup``): both stages, from one seed, toward a pose 1 km away (the
    pose stage fails at once, then the feature stage runs). Nothing when the task has no
    desired pose (no search) or the search is not compiled for it."""
    if desired_camera_pose(exp) is None:
        return
    lim = exp.limits
    far = np.eye(4)
    far[2, 3] = 1e3
    seeds = np.array([np.clip(exp.q0, lim.q_min, lim.q_max)], dtype=float)
    lo, hi = np.array(lim.q_min), np.array(lim.q_max)  # writable, as reachable()'s bounds
    _compiled_search(exp, far, seeds, lo, hi, 0.5 * exp.options.tolerance)


def feature_solution(
    exp: Any, seed: FloatArray, lo: FloatArray, hi: FloatArray, tol: float
) -> FloatArray | None:
    """Projected damped least squares on the task error ``e1(q)`` itself (the scene at t = 0):
    the ``q`` within ``[lo, hi]`` reaching ``‖e1‖ < tol`` from ``seed``, or None."""
    from redservo.errors import GeometryError

    q = np.clip(np.asarray(seed, dtype=float), lo, hi)
    stalled = Stall()
    for _ in range(150):
        bMc, J = exp.robot.kinematics(q, check_limits=False)
        try:
            st = exp.task.evaluate(exp.scene, bMc, J, 0.0)
        except GeometryError:
            return None
        size = float(np.linalg.norm(st.e1))
        if size < tol:
            return q
        if stalled(size):  # stuck against the bounds or in a local minimum
            return None
        if not np.all(np.isfinite(st.J1)):
            return None
        nxt = projected_step(st.J1, -st.e1, q, lo, hi, 1e-3, 0.3)
        if nxt is None:
            return None
        q = nxt
    return None


def reachable_column(values: Sequence[str]) -> np.ndarray | None:
    """The ``reachable`` column of ``samples.csv`` as booleans, or None when no row knows it
    (every value empty)."""
    if not any(values):
        return None
    return np.array([v == "True" for v in values], dtype=bool)
