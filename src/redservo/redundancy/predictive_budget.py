"""The predictive law's time budget and its fallback (docs/predictive.md, "Time budget").

With ``time_budget`` set, a step is *anytime*: the fallback (the ``qp`` law's command) is
computed first, then the model, the joint-goal search and each SQP iteration run only
while the budget lasts (the deadline is checked between them); a step whose deadline
passes returns the fallback already at hand, with ``solver-iterations`` (by the time
budget) and ``solver-fallback``. Only the QP solve under way when the deadline passes can
run past it (daqp cannot be interrupted). The clock is injectable (:attr:`Deadline.clock`)
so that tests use a fake time.

Units: seconds.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from redservo.kernels import flagbits as fb
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics, LawResult
from redservo.redundancy.flags import Flag
from redservo.redundancy.messages import events

__all__ = ["LOOP_SHARE", "Deadline", "fallback_result"]

LOOP_SHARE = 0.5
"""The share of a servo loop's period that a step of the law may take by default (the rest
for the measurement, the task, the safety stage and the robot's interface)."""


class Deadline:
    """The deadline of one step: ``budget`` seconds (None: no deadline) after ``clock()``
    at construction (``clock``: seconds, monotonic; default :func:`time.perf_counter`)."""

    def __init__(self, budget: float | None, clock: Callable[[], float] = time.perf_counter):
        self.clock = clock
        self.budget = budget
        self.t0 = clock()

    def elapsed(self) -> float:
        """Seconds since the step began."""
        return self.clock() - self.t0

    def at(self, fraction: float = 1.0) -> float | None:
        """The clock's reading when ``fraction`` of the budget has passed (None: none)."""
        return None if self.budget is None else self.t0 + fraction * self.budget

    def passed(self) -> bool:
        """The whole budget has passed (never without a budget)."""
        return self.budget is not None and self.elapsed() > self.budget


def fallback_result(
    res: LawResult, why: int, value: float, *, by_budget: bool, name: str, horizon: int
) -> LawResult:
    """The fallback law's result ``res`` as the predictive law's, with the flag bit ``why``
    (``value`` attached; ``by_budget``: the time budget caused it) and ``solver-fallback``."""
    vals = np.zeros(fb.N_FLAGS)
    src = np.zeros(fb.N_FLAGS, dtype=np.int64)
    vals[why] = value
    src[why] = fb.BY_TIME_BUDGET if by_budget else 1
    vals[fb.SOLVER_FALLBACK], src[fb.SOLVER_FALLBACK] = 1.0, fb.ONLY
    mask = (1 << why) | (1 << fb.SOLVER_FALLBACK)
    ev = events(
        mask,
        vals,
        src,
        horizon=horizon,
        fallback="qp",
        solver="predictive solve failed, qp law's command used",
    )
    d = res.diagnostics
    merged = Diagnostics(
        method=name,
        task_rank=d.task_rank,
        rank_deficient=d.rank_deficient,
        critical=d.critical,
        overconstrained=d.overconstrained,
        events=(*ev, *(e for e in d.events if e.flag is not Flag.SOLVER_FALLBACK)),
        info=d.info,
    )
    return LawResult(res.qdot, merged)


def warm_up(law: Any, limits: JointLimits, m: int, dt: float) -> None:
    """Pay a first call's one-time costs (compiled kernels loaded, the fallback's and daqp's
    first solves, lazy imports: about 0.2 s measured) on a synthetic task of ``m`` rows at the
    centre of ``limits`` (period ``dt``, s), outside any time budget: the law's clock is
    stopped meanwhile, so no deadline passes. :class:`~redservo.hardware.ServoLoop` calls
    ``law.warm_up`` before its first period, so that the first real step keeps within
    ``time_budget``; the caller then resets the law."""
    n = limits.q_min.shape[0]
    J1 = np.eye(m, n) + 0.1 * np.ones((m, n))
    clock, law.clock = law.clock, lambda: 0.0
    try:
        law(
            J1=J1,
            e1=np.full(m, 0.01),
            q=limits.center,
            limits=limits,
            lam=0.5,
            dt=dt,
            qdot_prev=np.zeros(n),
        )
    finally:
        law.clock = clock
