"""The law kernels by id: one compiled dispatch from a law's id and packed options to its kernel.

A law is selected by its id (:data:`LAW_IDS`); its options are read from the slots of
:mod:`redservo.kernels.lawopts` (packed by :func:`redservo.redundancy.kio.law_options`).
:func:`raw_law` returns the law's raw command and outputs in the common layout of
:mod:`redservo.kernels.laws`; :mod:`redservo.kernels.step` adds the safety layer and the
flag rules. Units: as the laws' (rad or m, s, 1/s).
"""

from __future__ import annotations

from typing import Any

from redservo.kernels._jit import kernel
from redservo.kernels.directional import directional, wln
from redservo.kernels.iterative import iterative
from redservo.kernels.lawopts import (
    F_CON_FILTER,
    F_CON_RCOND,
    F_DIR_MARGIN,
    F_E0,
    F_E1,
    F_GAIN,
    F_KAPPA,
    F_LAMBDA_TUNE,
    F_P_FILTER,
    F_RCOND,
    F_RHO,
    F_RHO1,
    F_ROBUST,
    F_SNS_MARGIN,
    I_AUTO_ROBUST,
    I_CURRENT,
    I_HAS_A,
    I_HAS_V,
    I_HISTORY,
    I_JOINT_FORCE,
    I_LEVELS,
    I_PROJECTOR,
    I_SHIELD,
    I_SMOOTH,
    V_AMAX,
    V_VMAX,
)
from redservo.kernels.laws import classical, gpm, gpm_auto, new_outputs
from redservo.kernels.projection import large_projection
from redservo.kernels.sns import sns

__all__ = ["F_SNS_SCALE", "I_SNS_BAD", "I_SNS_RESTORED", "LAW_IDS", "raw_law"]

LAW_IDS: dict[str, int] = {
    "classical": 0,
    "gpm": 1,
    "gpm-auto": 2,
    "iterative-basic": 3,
    "iterative": 4,
    "iterative-smooth": 5,
    "iterative-smooth-e2": 6,
    "directional": 7,
    "wln": 8,
    "sns": 9,
    "large-projection": 10,
}
"""Methods with a fully compiled step, and their ids."""
I_SNS_RESTORED, I_SNS_BAD, F_SNS_SCALE = 5, 6, 2
"""Where :func:`law_step` packs ``sns``'s restored flag, infeasible joint and task scale."""


@kernel
def _iterative(
    fopt: Any, iopt: Any, lp: Any, gains: Any, J1: Any, e: Any, q: Any, sec: Any, has_sec: bool
) -> Any:
    """The iterative family (ids 3-6) with its options read from their slots."""
    lam, dt = gains
    smooth, levels = iopt[I_SMOOTH] != 0, iopt[I_LEVELS]
    con_rcond, con_filter = fopt[F_CON_RCOND], fopt[F_CON_FILTER]
    rc, rb = fopt[F_RCOND], fopt[F_ROBUST]
    alpha = fopt[F_GAIN]
    return iterative(
        J1, e, q, lp, lam, dt, sec, has_sec, smooth, alpha, levels, rc, rb, con_rcond, con_filter
    )


@kernel
def _projection(
    fopt: Any,
    iopt: Any,
    lp: Any,
    lam: float,
    J1: Any,
    e1: Any,
    e: Any,
    q: Any,
    sec: Any,
    has_sec: bool,
) -> Any:
    """``large-projection`` (id 10) with its options read from their slots."""
    e0, e_1, proj = fopt[F_E0], fopt[F_E1], iopt[I_PROJECTOR]
    rho, rho1, tune = fopt[F_RHO], fopt[F_RHO1], fopt[F_LAMBDA_TUNE]
    rc, rb, pf = fopt[F_RCOND], fopt[F_ROBUST], fopt[F_P_FILTER]
    return large_projection(
        J1, e1, e, q, lp, lam, sec, has_sec, e0, e_1, proj, rho, rho1, tune, rc, rb, pf
    )


@kernel
def raw_law(law: Any, limits: Any, gains: Any, J1: Any, e1: Any, e: Any, q: Any, io: Any) -> Any:
    """The raw command of law ``law_id``, its options read from their slots
    (:mod:`redservo.kernels.lawopts`); ``io`` the optional inputs with their flags."""
    law_id, fopt, iopt, _ = law
    lp = limits[0]
    lam, dt = gains
    ff, has_ff, sec, has_sec, _, _, hist, has_hist = io
    rc = fopt[F_RCOND]
    rb = fopt[F_ROBUST]
    if law_id == 0:
        return classical(J1, e, lam, sec, has_sec, rc, rb)
    if law_id == 1:
        return gpm(J1, e, q, lp, lam, sec, has_sec, fopt[F_GAIN], rc, rb)
    if law_id == 2:
        current, robust = iopt[I_CURRENT] != 0, iopt[I_AUTO_ROBUST] != 0
        amax = fopt[F_GAIN]
        return gpm_auto(J1, e, q, lp, lam, dt, sec, has_sec, amax, current, rc, rb, robust)
    if law_id >= 3 and law_id <= 6:
        return _iterative(fopt, iopt, lp, gains, J1, e, q, sec, has_sec)
    if law_id == 7:
        kappa, force, mu = fopt[F_KAPPA], iopt[I_JOINT_FORCE] != 0, fopt[F_DIR_MARGIN]
        return directional(
            J1, e1, e, ff, has_ff, q, lp, lam, dt, sec, has_sec, kappa, force, mu, rc, rb
        )
    if law_id == 8:
        history = iopt[I_HISTORY] != 0
        return wln(J1, e, q, lp, lam, sec, has_sec, history, hist, has_hist, rc, rb, 1e-9)
    if law_id == 9:
        return _sns(law, limits, gains, J1, e, q, io)
    return _projection(fopt, iopt, lp, lam, J1, e1, e, q, sec, has_sec)


@kernel
def _sns(law: Any, limits: Any, gains: Any, J1: Any, e: Any, q: Any, io: Any) -> Any:
    """``sns`` with its outputs repacked in the common layout of :mod:`redservo.kernels.laws`
    (rank, free null-space dimension, iterations, scale < 1, restored, infeasible joint)."""
    _, fopt, iopt, vopt = law
    lp, has_v, has_a = limits
    lam, dt = gains
    _, _, sec, has_sec, prev, has_prev, _, _ = io
    out = sns(
        J1,
        e,
        q,
        lp,
        has_v,
        has_a,
        lam,
        dt,
        prev,
        has_prev,
        sec,
        has_sec,
        vopt[V_VMAX],
        iopt[I_HAS_V] != 0,
        vopt[V_AMAX],
        iopt[I_HAS_A] != 0,
        fopt[F_SNS_MARGIN],
        fopt[F_RCOND],
        iopt[I_SHIELD] != 0,
    )
    n = q.shape[0]
    qdot, iout, fout, axes, axf, vec = new_outputs(n, 0)
    for i in range(n):
        qdot[i] = out[0][i]
        axes[i] = 1 if out[2][i] else 0
    iout[0] = out[7]
    iout[2] = out[4]
    iout[3] = out[3]
    iout[4] = 1 if out[1] < 1.0 else 0
    iout[I_SNS_RESTORED] = 1 if out[5] else 0
    iout[I_SNS_BAD] = out[9]
    fout[F_SNS_SCALE] = out[1]
    fout[3] = out[6]
    return qdot, iout, fout, axes, axf, vec
