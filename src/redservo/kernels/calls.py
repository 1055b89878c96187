"""A law kernel and its flag rules in one compiled call (one dispatch from Python).

Each kernel here runs a law of :mod:`redservo.kernels.laws` and the matching flag rules of
:mod:`redservo.kernels.events`, and returns only what the law object reads: the command,
the few numbers its diagnostics and messages name, and ``(mask, vals, src)``. Calling the
two kernels from Python costs a second dispatch and the boxing of every output array; the
numbers are the same (the same kernels run).
"""

from __future__ import annotations

from typing import Any

from redservo.kernels._jit import kernel
from redservo.kernels.events import classical_events
from redservo.kernels.laws import F_COND, I_FILTERED, I_PROJ, I_RANK, classical

__all__ = ["classical_call"]


@kernel
def classical_call(
    J1: Any, e: Any, lam: float, sec: Any, has_sec: bool, rcond: float, robust: float
) -> Any:
    """:func:`~redservo.kernels.laws.classical` (arguments alike) and its
    :func:`~redservo.kernels.events.classical_events`: ``(q̇, rank, projector rank,
    filtered count, σ_max/σ_r, mask, vals, src)``."""
    m, n = J1.shape
    qdot, iout, fout, _, _, _ = classical(J1, e, lam, sec, has_sec, rcond, robust)
    mask, vals, src = classical_events(m, n, iout, robust)
    return qdot, iout[I_RANK], iout[I_PROJ], iout[I_FILTERED], fout[F_COND], mask, vals, src
