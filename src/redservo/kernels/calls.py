"""A law kernel and its flag rules in one compiled call (one dispatch from Python).

Each kernel here runs a law of :mod:`redservo.kernels.laws` and the matching flag rules of
:mod:`redservo.kernels.events`, and returns what the law object reads: the command, the
outputs it needs in the common layout of :mod:`redservo.kernels.laws` and ``(mask, vals,
src)``, which the law's ``diagnose`` turns into its diagnostics (the compiled controller
of :mod:`redservo.kernels.control` hands the same outputs to the same method). Calling the
two kernels from Python would cost a second dispatch; the numbers are the same.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.directional import directional
from redservo.kernels.events import (
    classical_events,
    directional_events,
    gpm_events,
    iterative_events,
    safety_with_events,
)
from redservo.kernels.iterative import iterative
from redservo.kernels.laws import classical, gpm

__all__ = [
    "classical_call",
    "classical_safe_call",
    "directional_call",
    "gpm_call",
    "iterative_call",
]


@kernel
def classical_call(
    J1: Any, e: Any, lam: float, sec: Any, has_sec: bool, rcond: float, robust: float
) -> Any:
    """:func:`~redservo.kernels.laws.classical` (arguments alike) and its
    :func:`~redservo.kernels.events.classical_events`: ``(q̇, iout, fout, mask, vals,
    src)``."""
    m, n = J1.shape
    qdot, iout, fout, _, _, _ = classical(J1, e, lam, sec, has_sec, rcond, robust)
    mask, vals, src = classical_events(m, n, iout, robust)
    return qdot, iout, fout, mask, vals, src


@kernel
def gpm_call(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    lam: float,
    sec: Any,
    has_sec: bool,
    alpha: float,
    rcond: float,
    robust: float,
) -> Any:
    """:func:`~redservo.kernels.laws.gpm` (arguments alike) and its
    :func:`~redservo.kernels.events.gpm_events`: ``(q̇, iout, fout, axes, mask, vals,
    src)``."""
    m, n = J1.shape
    out = gpm(J1, e, q, lp, lam, sec, has_sec, alpha, rcond, robust)
    qdot, iout, fout, axes = out[0], out[1], out[2], out[3]
    mask, vals, src = gpm_events(m, n, iout, robust)
    return qdot, iout, fout, axes, mask, vals, src


@kernel
def directional_call(
    J1: Any,
    e1: Any,
    e: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    lp: Any,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    kappa: float,
    use_jl: bool,
    mu: float,
    rcond: float,
    robust: float,
) -> Any:
    """:func:`~redservo.kernels.directional.directional` (arguments alike) and its
    :func:`~redservo.kernels.events.directional_events`: ``(q̇, iout, fout, axes, mask,
    vals, src)``."""
    m, n = J1.shape
    out = directional(
        J1, e1, e, ff, has_ff, q, lp, lam, dt, sec, has_sec, kappa, use_jl, mu, rcond, robust
    )
    qdot, iout, fout, axes = out[0], out[1], out[2], out[3]
    mask, vals, src = directional_events(m, n, iout, robust)
    return qdot, iout, fout, axes, mask, vals, src


@kernel
def iterative_call(
    J1: Any,
    e: Any,
    q: Any,
    lp: Any,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    smooth: bool,
    alpha: float,
    max_levels: int,
    rcond: float,
    robust: float,
    tol: float,
    constraint_robust: float,
) -> Any:
    """:func:`~redservo.kernels.iterative.iterative` (arguments alike) and its
    :func:`~redservo.kernels.events.iterative_events`: ``(q̇, iout, fout, axes, γ, vec,
    mask, vals, src)``."""
    m, n = J1.shape
    qdot, iout, fout, axes, gamma, vec = iterative(
        J1,
        e,
        q,
        lp,
        lam,
        dt,
        sec,
        has_sec,
        smooth,
        alpha,
        max_levels,
        rcond,
        robust,
        tol,
        constraint_robust,
    )
    mask, vals, src = iterative_events(m, n, iout, fout, vec, robust, constraint_robust)
    return qdot, iout, fout, axes, gamma, vec, mask, vals, src


@kernel
def classical_safe_call(
    J1: Any,
    e: Any,
    lam: float,
    sec: Any,
    has_sec: bool,
    rcond: float,
    robust: float,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    dt: float,
    prev: Any,
    has_prev: bool,
    shield: bool,
) -> Any:
    """:func:`classical_call` then the safety stage with uniform scaling
    (:func:`~redservo.kernels.events.safety_with_events`, arguments alike): the law's
    ``(iout, fout, mask, vals, src)``, then the safe ``(q̇, past_joint, accel_excess, mask,
    vals, src)``."""
    raw, iout, fout, mask, vals, src = classical_call(J1, e, lam, sec, has_sec, rcond, robust)
    none = np.zeros(q.shape[0])  # no task command: uniform scaling
    safe = safety_with_events(raw, q, lp, has_v, has_a, dt, prev, has_prev, shield, none, False)
    return (iout, fout, mask, vals, src, *safe)
