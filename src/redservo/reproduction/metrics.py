"""Small measurements on simulation logs shared by the experiments' checks.

Axes are numbered from 1 in everything returned to a report (``axis 1 = q[0]``);
iterations from 0. Units are those of the log: m or rad, m/s or rad/s, s.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray
from redservo.records.summary import SUCCESS_MARGIN
from redservo.records.summary import clear_of_limits as _clear
from redservo.simulation import SimulationLog, SimulationResult

__all__ = [
    "actual_velocity",
    "band_excess",
    "clear_of_limits",
    "decay_fit",
    "decay_rate",
    "first",
    "hit",
    "max_jump",
    "path_length",
    "reversals",
    "stopped_speed",
    "succeeded",
    "threshold",
    "translation_speed",
]


def first(mask: ArrayLike) -> int | None:
    """The first index where ``mask`` is true (non-zero), or None."""
    idx = np.flatnonzero(np.asarray(mask) > 0)
    return int(idx[0]) if idx.size else None


def threshold(rho: float) -> float:
    """Normalized position ``1 - 2ρ`` of the activation thresholds (docs/formulas.md §5.1)."""
    return 1.0 - 2.0 * rho


def band_excess(log: SimulationLog, thr: float) -> FloatArray:
    """(N, n) normalized band excess ``max(|q_norm| - thr, 0)``."""
    return np.maximum(np.abs(log.q_normalized) - thr, 0.0)


def reversals(x: FloatArray, rel: float = 0.01) -> int:
    """Sign reversals of ``x`` over the samples with ``|x| > rel max|x|``."""
    if x.size == 0:
        return 0
    big = x[np.abs(x) > rel * float(np.max(np.abs(x)))]
    return int(np.count_nonzero(np.diff(np.sign(big)) != 0))


def hit(r: SimulationResult) -> tuple[int | None, int | None]:
    """(axis numbered from 1, iteration) of the joint limit hit, or (None, None)."""
    h = r.summary["limit_hit"]
    return (h["axis"] + 1, h["iteration"]) if h else (None, None)


def clear_of_limits(r: SimulationResult) -> bool:
    """Every joint stayed at least the project's success margin
    (:data:`~redservo.records.summary.SUCCESS_MARGIN`, 1 % of its range) from its real limits
    all along the run: what "no joint limit reached" means in every check."""
    return _clear(float(r.summary["min_margin"]), SUCCESS_MARGIN)


def succeeded(r: SimulationResult) -> bool:
    """The run converged (``‖e1‖ < tolerance``, target in view) with every joint clear of its
    limits by the success margin (:func:`clear_of_limits`)."""
    return r.outcome == "converged" and clear_of_limits(r)


def translation_speed(r: SimulationResult) -> float:
    """Largest camera translation speed of a run (m/s)."""
    return float(r.summary["max_camera_speed"]["translation"])


def stopped_speed(log: SimulationLog, axis: int | None = None) -> float:
    """Largest ``|q̇_j|`` over the iterations where axis j is constrained (NaN if never).

    Args:
        log: The run's log.
        axis: 0-based axis, or None for every axis.
    """
    c = log.constrained > 0
    v = np.abs(log.qdot)
    if axis is not None:
        c, v = c[:, axis], v[:, axis]
    return float(np.max(v[c])) if c.any() else float("nan")


def decay_fit(t: FloatArray, error_norm: FloatArray) -> tuple[float, float]:
    """Fit ``log ‖e‖ = c - rate t`` by least squares; return (rate in 1/s, R²).

    Args:
        t: (N,) times (s), N >= 2.
        error_norm: (N,) positive error norms.
    """
    y = np.log(np.maximum(error_norm, 1e-300))
    A = np.vstack([t, np.ones_like(t)]).T
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    resid = y - A @ coef
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid**2)) / ss if ss > 0 else 1.0
    return -float(coef[0]), r2


def decay_rate(
    t: ArrayLike, x: ArrayLike, *, lo: float = 1e-4, hi: float = 1e-1, min_points: int = 5
) -> float:
    """Return the exponential decay rate (1/s) of ``|x|``: minus the slope of ``ln|x|`` vs ``t``.

    The least-squares fit uses the samples where ``lo |x0| < |x| < hi |x0|`` (``x0 = x[0]``),
    which skips the transient and the numerical floor.

    Args:
        t: (N,) times (s).
        x: (N,) signal (any units).
        lo: Lower bound of the fitted window, as a fraction of ``|x0|``.
        hi: Upper bound of the fitted window, as a fraction of ``|x0|``.
        min_points: Fewest samples in the window; fewer gives NaN.

    Returns:
        The rate (1/s), NaN when the window holds fewer than ``min_points`` samples.
    """
    ta, xa = np.asarray(t, dtype=float), np.abs(np.asarray(x, dtype=float))
    if xa.size == 0 or xa[0] == 0.0:
        return float("nan")
    k = np.flatnonzero((xa > lo * xa[0]) & (xa < hi * xa[0]))
    if k.size < min_points:
        return float("nan")
    slope = np.polyfit(ta[k], np.log(xa[k]), 1)[0]
    return float(-slope)


def path_length(q: ArrayLike) -> FloatArray:
    """Return (n,) the distance travelled by each joint, ``Σ_k |q_{k+1} - q_k|``, for q (N, n)."""
    qa = np.asarray(q, dtype=float)
    if qa.shape[0] < 2:
        return np.zeros(qa.shape[1])
    return np.asarray(np.abs(np.diff(qa, axis=0)).sum(axis=0))


def actual_velocity(log: SimulationLog, dt: float) -> FloatArray:
    """(N-1, n) joint velocities as the robot's odometry measures them: ``(q_{k+1} - q_k)/dt``.

    With an actuator model this is the mean velocity the joints really had over each
    period (lag and delay included), not the command ``q̇_k``.
    """
    return np.asarray(np.diff(log.q, axis=0) / dt)


def max_jump(v: ArrayLike) -> float:
    """``max_k ‖v_{k+1} - v_k‖`` of an (N, n) signal (0 with fewer than two samples)."""
    a = np.asarray(v, dtype=float)
    if a.shape[0] < 2:
        return 0.0
    return float(np.max(np.linalg.norm(np.diff(a, axis=0), axis=1)))


def as_int_list(idx: NDArray[Any]) -> list[int]:
    """Plain ``int`` list of a numpy index array, numbered from 1 (axes in a report)."""
    return [int(j) + 1 for j in np.asarray(idx).ravel()]
