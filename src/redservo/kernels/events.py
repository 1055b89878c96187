"""The flag rules of every law and of the safety layer, in one place (docs/safety.md).

Each kernel here takes the outputs of a law kernel (layouts in :mod:`redservo.kernels.laws`)
or of :func:`redservo.kernels.safety.apply_safety` and returns ``(mask, vals, src)``:

* ``mask`` int: bit ``j`` set when flag ``j`` of :mod:`redservo.kernels.flagbits` is raised
  (the order of :data:`redservo.redundancy.flags.FLAGS`);
* ``vals`` (:data:`N_FLAGS`,) float64: the number attached to each raised flag (its meaning
  is listed with the flag), from the first reason that raised it;
* ``src`` (:data:`N_FLAGS`,) int64: the reasons (source bits of :mod:`~redservo.kernels.flagbits`)
  that raised it, which choose its message.

The law objects turn these into :class:`~redservo.redundancy.flags.Event` records with
:func:`redservo.redundancy.messages.events`; the compiled loop keeps the mask. Nothing
else decides whether a flag is raised.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.flagbits import (
    ACC_KEPT_POSITION,
    ACC_RELEASED,
    ACCELERATION_EXCEEDED,
    ACCELERATION_LIMITED,
    AXES_NOT_HANDLED,
    BOUNDS_CONFLICT,
    BY_DIRECTIONAL,
    BY_TASK,
    DAMPED,
    DAMPED_ALPHA,
    DAMPED_CONSTRAINTS,
    DAMPED_PII,
    DAMPED_TASK,
    DAMPED_WEIGHTED,
    GAIN_ADJUSTED,
    GAIN_CAPPED,
    GAIN_NEGATIVE,
    GAIN_UNDEFINED,
    ILL_CONDITIONED,
    ILL_EXACT,
    ILL_ROBUST,
    LEAST_SQUARES,
    LS_LEVELS,
    LS_WEIGHTED,
    N_FLAGS,
    NO_REDUNDANCY,
    NO_SECONDARY,
    NON_FINITE_REPLACED,
    NORED_TASK,
    NORED_WLN,
    ONLY,
    OVERCONSTRAINED,
    POSITION_LIMIT_UNAVOIDABLE,
    RANK_LOSS,
    SCALED_QP,
    SCALED_SNS,
    SCALED_SNS_RESTORED,
    SHIELD_ACTED,
    SOLVER_FALLBACK,
    TASK_SCALED,
    VELOCITY_SCALED,
)
from redservo.kernels.laws import (
    ALPHA_CAPPED,
    ALPHA_FILTER,
    ALPHA_NEGATIVE,
    ALPHA_UNDEFINED,
    I_ALPHA_CODE,
    I_DAMPED,
    I_FILTERED,
    I_ITER,
    I_K,
    I_RANK,
)
from redservo.kernels.safety import apply_safety

__all__ = [
    "ILL_CONDITIONED_BELOW",
    "QP_RESIDUAL_RTOL",
    "classical_events",
    "directional_events",
    "gpm_auto_events",
    "gpm_events",
    "iterative_events",
    "large_projection_events",
    "qp_events",
    "safety_events",
    "safety_with_events",
    "sns_events",
    "wln_events",
]

ILL_CONDITIONED_BELOW = 1e-3
"""Iterative family: a constraint level whose smallest singular value is below this is
ill-conditioned (null-space motion amplified more than 1000x)."""
QP_RESIDUAL_RTOL = 1e-3
"""``qp``: a relative task residual above this means the bounds prevent the task."""

# iterative (kernels/iterative.py) and wln/directional (kernels/directional.py) outputs
_I_NCON, _I_NA, _F_MIN_SIGMA = 5, 6, 3
_I_ANY_Z = 8
_I_WRANK, _I_WFILTERED = 5, 6


@kernel
def _new() -> Any:
    return np.zeros(N_FLAGS), np.zeros(N_FLAGS, dtype=np.int64)


@kernel
def _raise(vals: Any, src: Any, flag: int, value: float, why: int) -> None:
    """Raise ``flag`` for reason ``why``; the value of its first reason is kept."""
    if src[flag] == 0:
        vals[flag] = value
    src[flag] |= why


@kernel
def _done(vals: Any, src: Any) -> Any:
    mask = 0
    for j in range(N_FLAGS):
        if src[j] != 0:
            mask |= 1 << j
    return mask, vals, src


@kernel
def _rank(vals: Any, src: Any, m: int, n: int, iout: Any, robust: float, nored: bool) -> None:
    """The task inverse: rank loss, no redundancy (``nored``), filtered directions."""
    rank = iout[I_RANK]
    if rank < m:
        _raise(vals, src, RANK_LOSS, m - rank, BY_TASK)
    if nored and rank >= n:
        _raise(vals, src, NO_REDUNDANCY, n, NORED_TASK)
    if iout[I_FILTERED] != 0:
        _raise(vals, src, DAMPED, 1.0 / robust, DAMPED_TASK)


@kernel
def classical_events(m: int, n: int, iout: Any, robust: float) -> Any:
    """``classical`` (and the base of ``large-projection``): no NO_REDUNDANCY."""
    vals, src = _new()
    _rank(vals, src, m, n, iout, robust, False)
    return _done(vals, src)


@kernel
def gpm_events(m: int, n: int, iout: Any, robust: float) -> Any:
    """``gpm``: the task inverse's flags."""
    vals, src = _new()
    _rank(vals, src, m, n, iout, robust, True)
    return _done(vals, src)


@kernel
def gpm_auto_events(m: int, n: int, iout: Any, cand: Any, robust: float, cap: float) -> Any:
    """``gpm-auto``: the task inverse, the candidates it does not stop, eq. 9's gain (its
    codes in :mod:`redservo.kernels.laws`); ``cap`` is ``alpha_max`` (inf: none)."""
    vals, src = _new()
    _rank(vals, src, m, n, iout, robust, True)
    k = iout[I_K]
    if k >= 0:
        others = 0
        for i in range(n):
            if i != k and cand[i] != 0.0:
                others += 1
        if others > 0:
            _raise(vals, src, AXES_NOT_HANDLED, others, ONLY)
        code = iout[I_ALPHA_CODE]
        if code == ALPHA_UNDEFINED:
            _raise(vals, src, GAIN_ADJUSTED, 0.0, GAIN_UNDEFINED)
        else:
            if iout[I_DAMPED] != 0:
                _raise(vals, src, DAMPED, 1.0 / ALPHA_FILTER, DAMPED_ALPHA)
            if code == ALPHA_NEGATIVE:
                _raise(vals, src, GAIN_ADJUSTED, 0.0, GAIN_NEGATIVE)
            elif code == ALPHA_CAPPED:
                _raise(vals, src, GAIN_ADJUSTED, cap, GAIN_CAPPED)
    return _done(vals, src)


@kernel
def unmet_levels(iout: Any, vec: Any) -> Any:
    """Iterative family: per level (1, 2, ...) solved, 1 where its constraints were met only
    in the least-squares sense (layout of :func:`redservo.kernels.iterative.iterative`)."""
    count = iout[I_ITER]
    n_a = iout[_I_NA]
    base = n_a + max(count - 1, 0) * n_a
    out = np.zeros(count, dtype=np.int64)
    for lv in range(count):
        out[lv] = 1 if vec[base + lv] != 0.0 else 0
    return out


@kernel
def iterative_events(
    m: int, n: int, iout: Any, fout: Any, vec: Any, robust: float, con_filter: float
) -> Any:
    """The iterative family: the task inverse and the constraint levels (``con_filter``: the
    robust filter of the constraint rows, 0 when off)."""
    vals, src = _new()
    _rank(vals, src, m, n, iout, robust, True)
    n_a = iout[_I_NA]
    if iout[_I_NCON] > n_a:
        _raise(vals, src, OVERCONSTRAINED, iout[_I_NCON] - n_a, ONLY)
    unmet = np.sum(unmet_levels(iout, vec))
    if unmet > 0:
        _raise(vals, src, LEAST_SQUARES, unmet, LS_LEVELS)
    min_sigma = fout[_F_MIN_SIGMA]
    if min_sigma < ILL_CONDITIONED_BELOW:
        why = ILL_ROBUST if con_filter != 0.0 else ILL_EXACT
        amp = 1.0 / min_sigma if min_sigma > 0.0 else np.inf
        _raise(vals, src, ILL_CONDITIONED, amp, why)
    if con_filter != 0.0 and min_sigma < con_filter:
        _raise(vals, src, DAMPED, 1.0 / con_filter, DAMPED_CONSTRAINTS)
    return _done(vals, src)


@kernel
def directional_events(m: int, n: int, iout: Any, robust: float) -> Any:
    """``directional``: filtered directions, rank loss, no secondary command."""
    vals, src = _new()
    rank = iout[I_RANK]
    if iout[I_FILTERED] != 0:
        _raise(vals, src, DAMPED, 1.0 / robust, DAMPED_TASK)
    if rank < m:
        _raise(vals, src, RANK_LOSS, m - rank, BY_DIRECTIONAL)
    if iout[_I_ANY_Z] == 0:
        _raise(vals, src, NO_SECONDARY, 0.0, ONLY)
    return _done(vals, src)


@kernel
def wln_events(m: int, n: int, iout: Any, robust: float) -> Any:
    """``wln``: the task inverse, the weighted one, the weighted rank loss."""
    vals, src = _new()
    _rank(vals, src, m, n, iout, robust, False)
    rank = iout[I_RANK]
    if iout[_I_WFILTERED] != 0 and iout[I_FILTERED] == 0:
        _raise(vals, src, DAMPED, 1.0 / robust, DAMPED_WEIGHTED)
    if iout[_I_WRANK] < rank:
        _raise(vals, src, LEAST_SQUARES, rank - iout[_I_WRANK], LS_WEIGHTED)
    if rank >= n:
        _raise(vals, src, NO_REDUNDANCY, n, NORED_WLN)
    return _done(vals, src)


@kernel
def sns_events(m: int, rank: int, scale: float, restored: bool) -> Any:
    """``sns``: rank loss, the task scale ``s < 1`` (``restored``: its best ``s*``)."""
    vals, src = _new()
    if rank < m:
        _raise(vals, src, RANK_LOSS, m - rank, BY_TASK)
    if scale < 1.0:
        _raise(vals, src, TASK_SCALED, scale, SCALED_SNS_RESTORED if restored else SCALED_SNS)
    return _done(vals, src)


@kernel
def large_projection_events(m: int, n: int, iout: Any, axes: Any, robust: float, pf: float) -> Any:
    """``large-projection``: the task inverse and its ``1/|P_ii|`` filter (``axes == 2``;
    ``pf`` the filter threshold)."""
    vals, src = _new()
    _rank(vals, src, m, n, iout, robust, False)
    for i in range(n):
        if axes[i] == 2:
            _raise(vals, src, DAMPED, 1.0 / pf if pf > 0.0 else np.inf, DAMPED_PII)
    return _done(vals, src)


@kernel
def qp_events(m: int, rank: int, conflicts: Any, fallback: bool, resid: float) -> Any:
    """``qp``: rank loss, joints whose bounds conflict, a solver fallback, the relative
    task residual (< 0: not computed)."""
    vals, src = _new()
    if rank < m:
        _raise(vals, src, RANK_LOSS, m - rank, BY_TASK)
    count = 0
    for i in range(conflicts.shape[0]):
        if conflicts[i]:
            count += 1
    if count > 0:
        _raise(vals, src, BOUNDS_CONFLICT, count, ONLY)
    if fallback:
        _raise(vals, src, SOLVER_FALLBACK, 1.0, ONLY)
    if resid > QP_RESIDUAL_RTOL:
        _raise(vals, src, TASK_SCALED, resid, SCALED_QP)
    return _done(vals, src)


@kernel
def safety_events(
    bad: int,
    s: float,
    over_v: bool,
    dropped: bool,
    change: float,
    acted: bool,
    worst: float,
    exceeded: bool,
    past: float,
) -> Any:
    """The safety layer, from the numbers of :func:`redservo.kernels.safety.apply_safety`."""
    vals, src = _new()
    if bad != 0:
        _raise(vals, src, NON_FINITE_REPLACED, bad, ONLY)
    if s < 1.0:
        _raise(vals, src, VELOCITY_SCALED if over_v else ACCELERATION_LIMITED, s, ONLY)
    if dropped:
        _raise(vals, src, ACCELERATION_EXCEEDED, np.nan, ACC_RELEASED)
    if acted:
        _raise(vals, src, SHIELD_ACTED, change, ONLY)
    if exceeded:
        _raise(vals, src, ACCELERATION_EXCEEDED, worst, ACC_KEPT_POSITION)
    if past > 0.0:
        _raise(vals, src, POSITION_LIMIT_UNAVOIDABLE, past, ONLY)
    return _done(vals, src)


@kernel
def safety_with_events(
    qdot: Any,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    dt: float,
    prev: Any,
    has_prev: bool,
    shield: bool,
    task: Any,
    has_task: bool,
) -> Any:
    """:func:`redservo.kernels.safety.apply_safety` and its :func:`safety_events` in one call:
    ``(q̇, past_joint, accel_excess, mask, vals, src)``."""
    out, bad, s, over_v, dropped, change, acted, worst, exceeded, past, joint = apply_safety(
        qdot, q, lp, has_v, has_a, dt, prev, has_prev, shield, task, has_task
    )
    mask, vals, src = safety_events(bad, s, over_v, dropped, change, acted, worst, exceeded, past)
    return out, joint, worst, mask, vals, src
