"""The summary of a compiled campaign run, reduced from the loop's buffers in one kernel call.

:func:`loop_summary` gives the :class:`~redservo.records.RunSummary` that
:func:`redservo.records.summarize` computes from the run's :class:`SimulationLog` (the
object path's summary), bit for bit, without building the log: :func:`reduce_run` walks
the loop's buffers ``Q``, ``QD``, ``TW``, ``EN``, ``FL`` once and returns the numbers the
summary keeps. Every float is the one numpy gives (tests/test_campaign_bulk.py):

* minima and maxima are exact whatever the order (a NaN wins, as in ``np.min``/``np.max``);
* the elementwise operations are the same IEEE operations (``min(q - q̄_min, q̄_max - q) /
  Δq̄``, ``|q̇| / q̇_max``, ``q̇_k - q̇_(k-1)``);
* a vector norm ``sqrt(Σ x²)`` adds the squares in the order of numpy's ``add.reduce``
  along a contiguous row (:func:`pairwise_sum`: sequential from ``-0.0`` below 8
  values, eight interleaved sums up to 128, halves above), which ``np.linalg.norm(...,
  axis=1)`` uses.

A run with measured collision pairs, or with no logged step, keeps :func:`summarize` (the
caller's fallback: :func:`loop_summary` returns None). Units: rad or m, s.
"""

from __future__ import annotations

import threading
import weakref
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.records.summary import (
    _ACCEL_RTOL,
    FlagCount,
    RunSummary,
    run_succeeded,
)
from redservo.redundancy.flags import FLAGS, Flag

__all__ = ["loop_summary", "pairwise_sum", "reduce_run"]

_SHIELD = Flag.SHIELD_ACTED.label
_LABELS = tuple(f.label for f in FLAGS)
_LAST = threading.local()
"""Per thread: the last experiment's bounds (a sample's methods share its experiment)."""


@kernel
def pairwise_sum(a: Any, start: int, n: int) -> float:
    """``a[start:start + n].sum()`` in numpy's order (module docstring)."""
    if n < 8:
        res = -0.0
        for i in range(n):
            res += a[start + i]
        return res
    if n <= 128:
        r = np.empty(8)
        for j in range(8):
            r[j] = a[start + j]
        i = 8
        while i < n - (n % 8):
            for j in range(8):
                r[j] += a[start + i + j]
            i += 8
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
        while i < n:
            res += a[start + i]
            i += 1
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return pairwise_sum(a, start, n2) + pairwise_sum(a, start + n2, n - n2)


@kernel
def _norm(v: Any, sq: Any) -> float:
    """``np.linalg.norm`` of one row ``v`` (its squares written into ``sq``)."""
    for j in range(v.shape[0]):
        sq[j] = v[j] * v[j]
    return float(np.sqrt(pairwise_sum(sq, 0, v.shape[0])))


@kernel
def _fmax(m: float, v: float) -> float:
    """``max`` as ``np.max`` reduces: a NaN, once met, stays."""
    return v if (v > m or v != v) else m


@kernel
def _fmin(m: float, v: float) -> float:
    """``min`` as ``np.min`` reduces: a NaN, once met, stays."""
    return v if (v < m or v != v) else m


@kernel
def reduce_run(rows: int, logs: Any, bounds: Any, has: Any, nflags: int) -> Any:
    """The summary's numbers of a run of ``rows`` (>= 1) logged steps.

    Args:
        rows: Logged steps.
        logs: The loop's buffers ``(Q, QD, TW, EN, FL)``.
        bounds: ``(q_min, q_max, range, qdot_max, accel_bound)``, (n,) each (the last two
            unused when ``has`` says so).
        has: ``(velocity limit, acceleration limit)`` flags.
        nflags: Number of flags (bits of ``FL``).

    Returns:
        ``(values, max_joint, counts, first)``: ``values`` = ``[min_margin, translation,
        rotation, discontinuity, final_error, peak_velocity_ratio]``, ``counts`` =
        ``[velocity_violations, acceleration_violations]`` then per flag its count;
        ``first`` the first iteration of each flag (0 when never raised).
    """
    Q, QD, TW, EN, FL = logs
    q_min, q_max, span, qdot_max, acc = bounds
    n = Q.shape[1]
    sq = np.empty(max(n, 3))
    values = np.zeros(6)
    max_joint = np.abs(QD[0])
    counts = np.zeros(2 + nflags, dtype=np.int64)
    first = np.zeros(nflags, dtype=np.int64)
    margin = _fmin(Q[0, 0] - q_min[0], q_max[0] - Q[0, 0]) / span[0]
    trans, rot = _norm(TW[0, :3], sq), _norm(TW[0, 3:], sq)
    disc, ratio = 0.0, abs(QD[0, 0]) / qdot_max[0]
    for k in range(rows):
        over_v = over_a = False
        for i in range(n):
            x, v = Q[k, i], QD[k, i]
            margin = _fmin(margin, _fmin(x - q_min[i], q_max[i] - x) / span[i])
            max_joint[i] = _fmax(max_joint[i], abs(v))
            ratio = _fmax(ratio, abs(v) / qdot_max[i])
            over_v = over_v or abs(v) > qdot_max[i]
            dv = v - (QD[k - 1, i] if k > 0 else 0.0)
            over_a = over_a or abs(dv) > acc[i]
            sq[i] = dv * dv
        if k > 0:  # the jump from the previous command (np.diff of the commands)
            jump = np.sqrt(pairwise_sum(sq, 0, n))
            disc = jump if k == 1 else _fmax(disc, jump)
        trans = _fmax(trans, _norm(TW[k, :3], sq))
        rot = _fmax(rot, _norm(TW[k, 3:], sq))
        counts[0] += over_v
        counts[1] += over_a
        for j in range(nflags):
            if (FL[k] >> j) & 1:
                if counts[2 + j] == 0:
                    first[j] = k
                counts[2 + j] += 1
    values[0], values[1], values[2] = margin, trans, rot
    values[3], values[4] = disc, EN[rows - 1]
    values[5] = ratio if has[0] else np.nan
    if not has[0]:
        counts[0] = 0
    if not has[1]:
        counts[1] = 0
    return values, max_joint, counts, first


def _bounds(exp: Any) -> tuple[tuple[Any, ...], Any]:
    """``(bounds, has)`` of :func:`reduce_run` for the experiment's limits and period."""
    lim, n = exp.limits, exp.robot.n
    ones = np.ones(n)
    v = ones if lim.qdot_max is None else np.broadcast_to(lim.qdot_max, (n,)).astype(float)
    a = ones
    if lim.qddot_max is not None:
        a = lim.qddot_max * exp.options.dt * (1.0 + _ACCEL_RTOL) + 1e-15  # as summarize's
        a = np.broadcast_to(a, (n,)).astype(float)
    f64 = np.float64
    bounds = (lim.q_min.astype(f64), lim.q_max.astype(f64), lim.range.astype(f64), v, a)
    has = np.array([lim.qdot_max is not None, lim.qddot_max is not None])
    return bounds, has


def loop_summary(
    exp: Any, rows: int, outcome: Any, hit: dict[str, int] | None, logs: tuple[Any, ...]
) -> RunSummary | None:
    """The :class:`RunSummary` of a compiled run without measured pairs (module
    docstring); None when ``rows`` is 0 (the caller then runs :func:`summarize`)."""
    if rows < 1:
        return None
    last = getattr(_LAST, "exp", None)
    if last is None or last[0]() is not exp:
        last = _LAST.exp = (weakref.ref(exp), *_bounds(exp))
    bounds, has = last[1], last[2]
    values, max_joint, counts, first = reduce_run(rows, logs, bounds, has, len(FLAGS))
    flags = {
        _LABELS[j]: FlagCount(int(counts[2 + j]), int(first[j]))
        for j in range(len(FLAGS))
        if counts[2 + j]
    }
    shield = flags[_SHIELD].count if _SHIELD in flags else 0
    margin = float(values[0])
    v_viol, a_viol = int(counts[0]), int(counts[1])
    min_margin = exp.options.min_margin
    success = run_succeeded(outcome, margin, min_margin, v_viol, a_viol, shield)
    return RunSummary(
        outcome=outcome,
        success=bool(success),
        iterations=rows,
        final_error_norm=float(values[4]),
        limit_hit=hit,
        min_margin=margin,
        min_margin_required=float(min_margin),
        max_joint_speed=max_joint.tolist(),
        peak_velocity_ratio=None if not has[0] else float(values[5]),
        velocity_violations=v_viol,
        acceleration_violations=a_viol,
        shield_activations=shield,
        max_camera_speed={"translation": float(values[1]), "rotation": float(values[2])},
        discontinuity=float(values[3]),
        flags=flags,
        collision=None,
        min_distance=None,
        closest_pair=None,
    )
