"""Reachability among obstacles: a goal configuration must be clear by ``d_safe``.

With obstacles or self pairs (``[collision]``, on or only measured), a sample's goal is
reachable when the search of :mod:`redservo.campaign.reach` finds a configuration that
meets the goal (the desired camera pose, or the task error below half the tolerance)
within the margin **and** whose every pair is at least ``d_safe`` apart (m): a goal only
met with a link in an obstacle, or closer than the shield allows, is not a goal any method
may reach. The seeds are those of the search, tried in order; the first clear solution
decides. On a redundant arm the goal configurations form a family and the seeds reach a
few of them: a goal whose every clear configuration is missed by the seeds is called
unreachable (the campaign report counts the successes on unreachable samples, as for the
joint-limit margin). The same criterion holds with and without avoidance, so the two
campaigns share their reachable samples. The feature stage keeps its meaning: a task with a
combination matrix (``e1 = C (s − s*)``, m < k) may converge at another camera pose, and a
clear configuration there counts, as a run converging there succeeds. Units: m, rad.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from redservo._validation import FloatArray

__all__ = ["clear_search", "goal_clearance"]


def goal_clearance(exp: Any) -> Callable[[FloatArray], bool] | None:
    """``clear(q)``: every pair of ``exp`` at least ``d_safe`` apart at ``q`` (the scene
    at t = 0; compiled geometry: :func:`~redservo.redundancy.predictive_distance.clear_of`);
    None without obstacles or self pairs."""
    c = exp.options.collision
    if c is None or not c.active:
        return None
    geo = c.compiled(exp.robot)
    if geo is not None:  # one compiled call, the broad phase first: the same verdict
        from redservo.redundancy.predictive_distance import clear_of

        return clear_of(geo, c.d_safe)

    def clear(q: FloatArray) -> bool:
        d = c.measure(exp.robot, np.asarray(q, dtype=float), 0.0).d
        return bool(d.size == 0 or float(np.min(d)) >= c.d_safe)

    return clear


def clear_search(
    exp: Any,
    target: FloatArray,
    seeds: list[FloatArray],
    lo: FloatArray,
    hi: FloatArray,
    tol: float,
    clear: Callable[[FloatArray], bool],
    feature_solution: Callable[..., FloatArray | None],
) -> bool:
    """Whether some seed's solution meets the goal and is ``clear`` (module docstring);
    ``feature_solution(exp, seed, lo, hi, tol)`` is the feature-space search of
    :mod:`redservo.campaign.reach` (passed in: that module imports this one)."""
    pose, feature = _stages(exp, target, lo, hi, tol, feature_solution)
    for stage in (pose, feature):
        for seed in seeds:
            q = stage(seed)
            if q is not None and clear(q):
                return True
    return False


Stage = Callable[[FloatArray], FloatArray | None]


def _stages(
    exp: Any,
    target: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    tol: float,
    feature_solution: Callable[..., FloatArray | None],
) -> tuple[Stage, Stage]:
    """The pose and feature searches from one seed, each returning where it reaches the goal
    (or None): the compiled kernels of :mod:`redservo.kernels.reach` when the robot (and,
    for the feature stage, the scene) has a compiled form, as the obstacle-free search runs
    them (same steps; last bits of numpy's arithmetic may differ, not the verdicts:
    tests/test_reach_compiled.py); else the Python searches."""
    from redservo.campaign.looppack import (
        robot_args,
        robot_reason,
        scene_reason,
        search_scene_args,
        task_args,
    )
    from redservo.robots.ik import solve_ik

    def py_pose(seed: FloatArray) -> FloatArray | None:
        return solve_ik(exp.robot, target, seed, lo, hi)

    def py_feature(seed: FloatArray) -> FloatArray | None:
        return feature_solution(exp, seed, lo, hi, tol)

    if robot_reason(exp) is not None:
        return py_pose, py_feature
    from redservo.kernels import reach as kr

    robot, c = robot_args(exp), np.ascontiguousarray
    lo_c, hi_c, tg = c(lo, dtype=np.float64), c(hi, dtype=np.float64), c(target, float)

    def pose(seed: FloatArray) -> FloatArray | None:
        ok, q = kr.pose_solution(robot, tg, c(seed, dtype=np.float64), lo_c, hi_c, 300, 1e-3)
        return np.asarray(q) if ok else None

    if scene_reason(exp) is not None:
        return pose, py_feature
    scene, task = search_scene_args(exp), task_args(exp)

    def feature(seed: FloatArray) -> FloatArray | None:
        ok, q = kr.feature_solution(robot, scene, task, c(seed, dtype=np.float64), lo_c, hi_c, tol)
        return np.asarray(q) if ok else None

    return pose, feature
