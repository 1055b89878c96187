"""One law call and its safety layer in compiled code, the law chosen by an id.

:func:`law_step` (driven by the step kernel, :mod:`redservo.kernels.control`) is what a batched
closed loop calls for each sample (the simulator's ``simulate`` runs the same kernels one
object at a time). A law is selected by its id
(:data:`LAW_IDS`) and its options are packed by
:func:`redservo.redundancy.kio.law_options` into a float array ``fopt`` and an int
array ``iopt`` (layout below); ``vopt`` (2, n) holds per-joint options (``sns``'s
``v_max`` and ``a_max``, inf when absent). ``qp`` is not here: its solver is a Python
library (the law calls the kernels of :mod:`redservo.kernels.qp` around it).

Option layout: the named slots of :mod:`redservo.kernels.lawopts` (each law's options declare
theirs, ``Law.OPTIONS``).

Step outputs: the law's ``(q̇, iout, fout, axes, axf, vec)`` (:mod:`redservo.kernels.laws`)
with ``q̇`` after the safety layer, and ``sout`` (11,): the numbers of
:func:`redservo.kernels.safety.apply_safety` (non-finite count, scale, over-velocity,
dropped, shield change, shield acted, acceleration excess, exceeded), the law's raw
``|q̇|∞``, the distance past a hard limit no command could avoid (0: none) and that
joint.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.directional import directional, wln
from redservo.kernels.events import (
    classical_events,
    directional_events,
    gpm_auto_events,
    gpm_events,
    iterative_events,
    large_projection_events,
    safety_events,
    sns_events,
    wln_events,
)
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
    I_FIRST,
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
from redservo.kernels.safety import apply_safety
from redservo.kernels.sns import sns

__all__ = [
    "I_SNS_BAD",
    "LAW_IDS",
    "law_events",
    "law_raw",
    "law_step",
    "sout_events",
    "step_events",
]

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
NS = 11
I_SNS_RESTORED, I_SNS_BAD, F_SNS_SCALE = 5, 6, 2
"""Where :func:`law_step` packs ``sns``'s restored flag, infeasible joint and task scale."""


@kernel
def _raw_law(law: Any, limits: Any, gains: Any, J1: Any, e1: Any, e: Any, q: Any, io: Any) -> Any:
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
        smooth, levels = iopt[I_SMOOTH] != 0, iopt[I_LEVELS]
        con_rcond, con_filter = fopt[F_CON_RCOND], fopt[F_CON_FILTER]
        return iterative(
            J1,
            e,
            q,
            lp,
            lam,
            dt,
            sec,
            has_sec,
            smooth,
            fopt[F_GAIN],
            levels,
            rc,
            rb,
            con_rcond,
            con_filter,
        )
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
    return large_projection(
        J1,
        e1,
        e,
        q,
        lp,
        lam,
        sec,
        has_sec,
        fopt[F_E0],
        fopt[F_E1],
        iopt[I_PROJECTOR],
        fopt[F_RHO],
        fopt[F_RHO1],
        fopt[F_LAMBDA_TUNE],
        rc,
        rb,
        fopt[F_P_FILTER],
    )


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


@kernel
def _given(x: Any, n: int) -> Any:
    """An optional input as the law kernels take it: ``(x, True)``, or zeros and False when
    ``x`` is empty (absent)."""
    if x.shape[0] > 0:
        return x, True
    return np.zeros(n), False


@kernel
def _prepared(gains: Any, e1: Any, q: Any, inputs: Any) -> Any:
    """``(e, io)``: the effective error ``e = e1 + ff/λ`` (CM01 eq. 2) and the optional
    inputs ``(ff, sec, prev, hist)`` (empty when absent) with their flags, as the law
    kernels take them."""
    n = q.shape[0]
    m = e1.shape[0]
    ff_in, sec_in, prev_in, hist_in = inputs
    ff, has_ff = _given(ff_in, m)
    sec, has_sec = _given(sec_in, n)
    prev, has_prev = _given(prev_in, n)
    hist, has_hist = _given(hist_in, n)
    lam = gains[0]
    e = np.empty(m)
    for i in range(m):
        e[i] = e1[i] + ff[i] / lam if has_ff else e1[i]  # effective error, CM01 eq. 2
    return e, (ff, has_ff, sec, has_sec, prev, has_prev, hist, has_hist)


@kernel
def law_raw(law: Any, limits: Any, gains: Any, J1: Any, e1: Any, q: Any, inputs: Any) -> Any:
    """The law's raw command, before the safety layer, and its events (arguments as
    :func:`law_step`): ``(q̇, iout, fout, axes, axf, vec, mask, vals, src)``; what a law
    object's :meth:`~redservo.redundancy.Law.compute` returns for secondary-first scaling."""
    e, io = _prepared(gains, e1, q, inputs)
    qdot, iout, fout, axes, axf, vec = _raw_law(law, limits, gains, J1, e1, e, q, io)
    mask, vals, src = law_events(law[0], law[1], e1.shape[0], iout, fout, axes, axf, vec)
    return qdot, iout, fout, axes, axf, vec, mask, vals, src


@kernel
def law_step(
    law: Any,
    limits: Any,
    gains: Any,
    J1: Any,
    e1: Any,
    q: Any,
    inputs: Any,
) -> Any:
    """One law call and its safety layer on plain arrays (module docstring).

    Packs: ``law`` ``(law_id, fopt, iopt, vopt)``, ``limits`` ``(rows, has_v, has_a)``,
    ``gains`` ``(λ, dt)``; ``inputs`` ``(ff, sec, prev, hist)``: the feed-forward (m,), the
    secondary command (n,), the previous command (n,) and ``wln``'s history (n,), each an
    empty array when absent."""
    lam, dt = gains
    _, fopt, iopt, _ = law
    lp, has_v, has_a = limits
    e, io = _prepared(gains, e1, q, inputs)
    _, _, sec, _, prev, has_prev, _, _ = io
    qdot, iout, fout, axes, axf, vec = _raw_law(law, limits, gains, J1, e1, e, q, io)
    task = qdot
    first = iopt[I_FIRST] != 0
    if first:
        task = classical(J1, e, lam, sec, False, fopt[F_RCOND], fopt[F_ROBUST])[0]
    out, bad, s, over_v, dropped, change, acted, worst, exceeded, past, joint = apply_safety(
        qdot, q, lp, has_v, has_a, dt, prev, has_prev, iopt[I_SHIELD] != 0, task, first
    )
    sout = np.empty(NS)
    sout[0] = bad
    sout[1] = s
    sout[2] = 1.0 if over_v else 0.0
    sout[3] = 1.0 if dropped else 0.0
    sout[4] = change
    sout[5] = 1.0 if acted else 0.0
    sout[6] = worst
    sout[7] = 1.0 if exceeded else 0.0
    big = 0.0
    for i in range(qdot.shape[0]):
        big = max(big, abs(qdot[i]))
    sout[8] = big
    sout[9] = past
    sout[10] = joint
    return out, iout, fout, axes, axf, vec, sout


@kernel
def law_events(
    law_id: int,
    fopt: Any,
    m: int,
    iout: Any,
    fout: Any,
    axes: Any,
    axf: Any,
    vec: Any,
) -> Any:
    """``(mask, vals, src)`` of the events of law ``law_id`` from its outputs in the common
    layout (:mod:`redservo.kernels.laws`): the kernel of :mod:`redservo.kernels.events` the
    law object calls, with the same arguments."""
    n = axes.shape[0]
    rb = fopt[F_ROBUST]
    if law_id == 0:
        return classical_events(m, n, iout, rb)
    if law_id == 1:
        return gpm_events(m, n, iout, rb)
    if law_id == 2:
        return gpm_auto_events(m, n, iout, axf, rb, fopt[F_GAIN])
    if law_id >= 3 and law_id <= 6:
        return iterative_events(m, n, iout, fout, vec, rb, fopt[F_CON_FILTER])
    if law_id == 7:
        return directional_events(m, n, iout, rb)
    if law_id == 8:
        return wln_events(m, n, iout, rb)
    if law_id == 9:
        restored = iout[I_SNS_RESTORED] != 0
        return sns_events(m, iout[0], fout[F_SNS_SCALE], restored)
    return large_projection_events(m, n, iout, axes, rb, fopt[F_P_FILTER])


@kernel
def sout_events(sout: Any) -> Any:
    """``(mask, vals, src)`` of the safety layer from the numbers ``sout`` of
    :func:`law_step`."""
    return safety_events(
        int(sout[0]),
        sout[1],
        sout[2] != 0,
        sout[3] != 0,
        sout[4],
        sout[5] != 0,
        sout[6],
        sout[7] != 0,
        sout[9],
    )


@kernel
def step_events(
    law_id: int,
    fopt: Any,
    m: int,
    iout: Any,
    fout: Any,
    axes: Any,
    axf: Any,
    vec: Any,
    sout: Any,
) -> int:
    """The event mask (bit ``j`` = flag ``j`` of :mod:`redservo.kernels.flagbits`) of one
    :func:`law_step`: its law's events (:func:`law_events`) and the safety layer's."""
    mask = law_events(law_id, fopt, m, iout, fout, axes, axf, vec)[0]
    return mask | sout_events(sout)[0]
