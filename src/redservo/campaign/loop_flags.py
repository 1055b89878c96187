"""The diagnostic flags of a compiled step, as a bit mask (bit ``j`` is ``FLAGS[j]``).

The campaign loop (:mod:`redservo.campaign.loop_kernel`) needs, per step, only which flags
were raised (the run summary counts them). :func:`law_flags` applies the rules of each
law's ``compute`` in :mod:`redservo.redundancy` (``rank_events`` and the law's own events)
to the integer and float outputs of its kernel, and :func:`safety_flags` those of
:func:`redservo.redundancy.safety.safety_events`; the messages and numbers are not needed.
tests/test_campaign_fast.py checks the masks against the law objects' events on random steps
(every law, options varied, robust on and off) and the flag counts of whole runs: a change of
a law's events must be mirrored here, and those tests say so.
"""

from __future__ import annotations

from typing import Any

from redservo.kernels._jit import kernel
from redservo.kernels.directional import I_ANY_Z, I_WFILTERED, I_WRANK
from redservo.kernels.iterative import F_MIN_SIGMA, I_NA, I_NCON
from redservo.kernels.laws import (
    ALPHA_CAPPED,
    ALPHA_NEGATIVE,
    ALPHA_UNDEFINED,
    I_ALPHA_CODE,
    I_DAMPED,
    I_FILTERED,
    I_ITER,
    I_K,
    I_RANK,
)
from redservo.kernels.step import LAW_IDS
from redservo.redundancy.flags import FLAGS, Flag
from redservo.redundancy.iterative import ILL_CONDITIONED as ILL_CONDITIONED_BELOW

__all__ = ["I_SNS_BAD", "law_flags", "safety_flags"]

_BIT = {flag: 1 << j for j, flag in enumerate(FLAGS)}
RANK_LOSS = _BIT[Flag.RANK_LOSS]
NO_REDUNDANCY = _BIT[Flag.NO_REDUNDANCY]
ILL_CONDITIONED = _BIT[Flag.ILL_CONDITIONED]
DAMPED = _BIT[Flag.DAMPED]
OVERCONSTRAINED = _BIT[Flag.OVERCONSTRAINED]
LEAST_SQUARES = _BIT[Flag.LEAST_SQUARES]
AXES_NOT_HANDLED = _BIT[Flag.AXES_NOT_HANDLED]
GAIN_ADJUSTED = _BIT[Flag.GAIN_ADJUSTED]
TASK_SCALED = _BIT[Flag.TASK_SCALED]
SOLVER_FALLBACK = _BIT[Flag.SOLVER_FALLBACK]
BOUNDS_CONFLICT = _BIT[Flag.BOUNDS_CONFLICT]
NO_SECONDARY = _BIT[Flag.NO_SECONDARY]
VELOCITY_SCALED = _BIT[Flag.VELOCITY_SCALED]
ACCELERATION_LIMITED = _BIT[Flag.ACCELERATION_LIMITED]
ACCELERATION_EXCEEDED = _BIT[Flag.ACCELERATION_EXCEEDED]
SHIELD_ACTED = _BIT[Flag.SHIELD_ACTED]
NON_FINITE_REPLACED = _BIT[Flag.NON_FINITE_REPLACED]
POSITION_LIMIT_UNAVOIDABLE = _BIT[Flag.POSITION_LIMIT_UNAVOIDABLE]

_GPM = LAW_IDS["gpm"]
_GPM_AUTO = LAW_IDS["gpm-auto"]
_ITER_FIRST = LAW_IDS["iterative-basic"]
_ITER_LAST = LAW_IDS["iterative-smooth-e2"]
_DIRECTIONAL = LAW_IDS["directional"]
_WLN = LAW_IDS["wln"]
_SNS = LAW_IDS["sns"]
_LARGE_PROJECTION = LAW_IDS["large-projection"]
I_SNS_BAD, F_SNS_SCALE = 6, 2
"""Where :func:`redservo.kernels.step.law_step` packs ``sns``'s infeasible joint and scale."""


@kernel
def law_flags(
    law_id: int,
    m: int,
    n: int,
    iout: Any,
    fout: Any,
    axes: Any,
    axf: Any,
    vec: Any,
    fopt: Any,
    has_cap: bool,
) -> int:
    """Bit mask of the flags a law's ``compute`` raises, from its kernel's outputs.

    ``has_cap``: ``gpm-auto`` has an ``alpha_max``. Mirrors the events of
    :mod:`redservo.redundancy` (``rank_events`` and each law's own).
    """
    rank = iout[I_RANK]
    if law_id == _SNS:
        bits = RANK_LOSS if rank < m else 0
        return bits | (TASK_SCALED if fout[F_SNS_SCALE] < 1.0 else 0)
    rank_b = RANK_LOSS if rank < m else 0
    nored_b = NO_REDUNDANCY if rank >= n else 0
    damped_b = DAMPED if iout[I_FILTERED] != 0 else 0
    if law_id == _GPM:
        return rank_b | nored_b | damped_b
    if law_id == _GPM_AUTO:
        bits = rank_b | nored_b | damped_b
        k = iout[I_K]
        if k >= 0:
            for i in range(n):
                if i != k and axf[i] != 0.0:
                    bits |= AXES_NOT_HANDLED
            code = iout[I_ALPHA_CODE]
            if code == ALPHA_UNDEFINED:
                return bits | GAIN_ADJUSTED
            if iout[I_DAMPED] != 0:
                bits |= DAMPED
            if code == ALPHA_NEGATIVE or (code == ALPHA_CAPPED and has_cap):
                bits |= GAIN_ADJUSTED
        return bits
    if law_id >= _ITER_FIRST and law_id <= _ITER_LAST:
        bits = rank_b | nored_b | damped_b
        count = iout[I_ITER]
        n_a = iout[I_NA]
        nb = max(count - 1, 0) * n_a
        if iout[I_NCON] > n_a:
            bits |= OVERCONSTRAINED
        for lv in range(1, count + 1):
            if vec[n_a + nb + lv - 1] != 0.0:
                bits |= LEAST_SQUARES
        min_sigma = fout[F_MIN_SIGMA]
        if min_sigma < ILL_CONDITIONED_BELOW:
            bits |= ILL_CONDITIONED
        if fopt[4] != 0.0 and min_sigma < fopt[4]:
            bits |= DAMPED
        return bits
    if law_id == _DIRECTIONAL:
        return damped_b | rank_b | (NO_SECONDARY if iout[I_ANY_Z] == 0 else 0)
    if law_id == _WLN:
        bits = rank_b | damped_b | nored_b
        if iout[I_WFILTERED] != 0 and iout[I_FILTERED] == 0:
            bits |= DAMPED
        if iout[I_WRANK] < rank:
            bits |= LEAST_SQUARES
        return bits
    if law_id == _LARGE_PROJECTION:
        for i in range(n):
            if axes[i] == 2:  # its robust 1/|P_ii| filter acted on axis i
                damped_b = DAMPED
    return rank_b | damped_b  # classical, large-projection: no NO_REDUNDANCY


@kernel
def safety_flags(
    bad: float, s: float, over_v: bool, dropped: bool, acted: bool, exc: bool, past: float
) -> int:
    """Bit mask of the events of :func:`redservo.redundancy.safety.apply_safety` from the
    numbers of :func:`redservo.kernels.safety.apply_safety` (``past > 0``: a joint passes
    its hard limit and no command could avoid it)."""
    bits = 0
    if past > 0.0:
        bits |= POSITION_LIMIT_UNAVOIDABLE
    if bad != 0:
        bits |= NON_FINITE_REPLACED
    if s < 1.0:
        bits |= VELOCITY_SCALED if over_v else ACCELERATION_LIMITED
    if dropped or exc:
        bits |= ACCELERATION_EXCEEDED
    if acted:
        bits |= SHIELD_ACTED
    return bits
