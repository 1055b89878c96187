"""An independent second opinion on a campaign sample's reachability.

:mod:`redservo.campaign.reach` decides reachability with the projected damped least squares of
:mod:`redservo.robots.ik`, the same solver, damping, tolerances and seed generator as the
``predictive`` law's goal search (:mod:`redservo.redundancy.predictive_goal`). A law that
succeeds where that search failed, or a search that agrees with the law because both share a
blind spot, cannot be told apart with it alone. This module answers the same question with
nothing in common but the robot's forward kinematics:

* **another formulation**: bounded nonlinear least squares (:func:`scipy.optimize.least_squares`,
  trust-region reflective ``"trf"``) on the residual ``(t, θu)`` of ``c*Mc`` (camera pose
  error to the desired pose, m and rad), with a finite-difference Jacobian (the robot's
  analytic Jacobian is not used); for tasks met at other poses (moments), on the task error
  ``e1(q)`` itself;
* **other seeds**: a scrambled Sobol sequence (:data:`SOBOL_SEEDS` points, scramble seed
  :data:`SOBOL_SCRAMBLE`) spanning the bounds, nothing derived from the sample's start.

Reachable means the same as in :mod:`redservo.campaign.reach`: every joint at least ``margin``
of its range inside its limits, the pose within :data:`redservo.robots.ik.POS_TOL` /
:data:`redservo.robots.ik.ROT_TOL`, or the task error below half the convergence tolerance.
:func:`disagreements` lists the samples the two methods judge differently. Units: metres,
radians.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from redservo._validation import FloatArray

__all__ = ["SOBOL_SCRAMBLE", "SOBOL_SEEDS", "disagreements", "reachable_independent"]

SOBOL_SEEDS = 32
"""Sobol starting points tried per sample (a power of two keeps the sequence balanced)."""
SOBOL_SCRAMBLE = 20050405
"""Seed of the Sobol scrambling (not the generator of :mod:`redservo.campaign.reach`)."""
_MAX_EVALS = 400
"""Residual evaluations allowed per start (finite differences excluded)."""
_TOLS = {"xtol": 1e-12, "ftol": 1e-12, "gtol": 1e-12}
"""Stop only when converged (the tolerances of reachability are checked afterwards)."""


def _bounds(exp: Any, margin: float | None) -> tuple[FloatArray, FloatArray]:
    lim = exp.limits
    m = exp.options.min_margin if margin is None else margin
    rng = lim.q_max - lim.q_min
    return lim.q_min + m * rng, lim.q_max - m * rng


def _sobol(lo: FloatArray, hi: FloatArray, count: int) -> FloatArray:
    """``count`` scrambled Sobol points in the box ``[lo, hi]``, shape (count, n)."""
    from scipy.stats import qmc

    unit = qmc.Sobol(d=lo.size, scramble=True, seed=SOBOL_SCRAMBLE).random(count)
    return np.asarray(qmc.scale(unit, lo, hi))


def _pose_residual(exp: Any, target: FloatArray) -> Callable[[FloatArray], FloatArray]:
    from redservo.spatial import inverse, matrix_to_rotvec

    tinv = inverse(target)

    def residual(q: FloatArray) -> FloatArray:
        bMc, _ = exp.robot.kinematics(q, check_limits=False)
        tMc = tinv @ bMc
        return np.concatenate([tMc[:3, 3], matrix_to_rotvec(tMc[:3, :3])])

    return residual


def _task_residual(exp: Any) -> Callable[[FloatArray], FloatArray]:
    def residual(q: FloatArray) -> FloatArray:
        bMc, J = exp.robot.kinematics(q, check_limits=False)
        e1 = np.asarray(exp.task.evaluate(exp.scene, bMc, J, 0.0).e1, dtype=float)
        return e1 if np.all(np.isfinite(e1)) else np.full(e1.shape, 1e3)

    return residual


def _solves(
    residual: Callable[[FloatArray], FloatArray],
    seed: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    met: Callable[[FloatArray], bool],
) -> bool:
    from scipy.optimize import least_squares

    from redservo.errors import GeometryError

    x0 = np.clip(seed, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))  # trf: strictly inside
    try:
        sol = least_squares(
            residual, x0, bounds=(lo, hi), method="trf", max_nfev=_MAX_EVALS, **_TOLS
        )
    except (GeometryError, ValueError, np.linalg.LinAlgError):
        return False
    return bool(np.all(sol.x >= lo) and np.all(sol.x <= hi) and met(residual(sol.x)))


def reachable_independent(
    exp: Any, *, margin: float | None = None, seeds: int = SOBOL_SEEDS
) -> bool | None:
    """Whether the sample's goal is reachable with every joint at least ``margin`` (a fraction
    of its range, default the scenario's ``min_margin``) inside its limits, decided without
    :mod:`redservo.robots.ik` (module docstring); None when the task has no desired pose."""
    from redservo.campaign.reach import desired_camera_pose
    from redservo.robots.ik import POS_TOL, ROT_TOL

    target = desired_camera_pose(exp)
    if target is None:
        return None
    lo, hi = _bounds(exp, margin)
    starts = _sobol(lo, hi, seeds)
    pose = _pose_residual(exp, target)

    def pose_met(r: FloatArray) -> bool:
        return bool(np.linalg.norm(r[:3]) < POS_TOL and np.linalg.norm(r[3:]) < ROT_TOL)

    if any(_solves(pose, s, lo, hi, pose_met) for s in starts):
        return True
    tol = 0.5 * exp.options.tolerance
    task = _task_residual(exp)
    return any(_solves(task, s, lo, hi, lambda r: bool(np.linalg.norm(r) < tol)) for s in starts)


def disagreements(
    samples: Sequence[int], first: Sequence[bool | None], second: Sequence[bool | None]
) -> list[tuple[int, bool, bool]]:
    """``(sample, first, second)`` for each sample both methods judged and judged differently
    (``first``: :func:`redservo.campaign.reach.reachable`, ``second``:
    :func:`reachable_independent`)."""
    return [
        (int(i), bool(a), bool(b))
        for i, a, b in zip(samples, first, second, strict=True)
        if a is not None and b is not None and bool(a) != bool(b)
    ]
