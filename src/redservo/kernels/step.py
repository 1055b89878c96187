"""One law call and its safety layer in compiled code, the law chosen by an id.

:func:`law_step` (with the task kernels of :mod:`redservo.kernels.tasks`) is what a batched
closed loop calls for each sample (the simulator's ``simulate`` runs the same kernels one
object at a time). A law is selected by its id
(:data:`LAW_IDS`) and its options are packed by
:func:`redservo.redundancy.kio.law_options` into a float array ``fopt`` and an int
array ``iopt`` (layout below); ``vopt`` (2, n) holds per-joint options (``sns``'s
``v_max`` and ``a_max``, inf when absent). ``qp`` is not here: its solver is a Python
library (the law calls the kernels of :mod:`redservo.kernels.qp` around it).

Option layout, common to every law: ``fopt[0]`` rcond, ``fopt[1]`` the robust filter
threshold ε (0 when ``robust`` is off), ``iopt[0]`` shield, ``iopt[1]`` secondary-first
scaling; then per law (index: meaning):

* gpm: f2 α · gpm-auto: f2 α_max (inf: none), i2 current rule, i3 robust
* iterative family: i2 smooth, f2 α of the e2 term (0: none), i3 max levels (-1: none),
  f3 constraint cut-off, f4 constraint filter
* directional: f2 κ, i2 joint-limit force, f3 margin μ · wln: i2 history mode
* sns: f2 margin, i2 has v_max, i3 has a_max · large-projection: f2 e0, f3 e1, i2 mode,
  f4 ρ, f5 ρ1, f6 λ_tune, f7 P filter

Step outputs: the law's ``(q̇, iout, fout, axes, axf, vec)`` (:mod:`redservo.kernels.laws`)
with ``q̇`` after the safety layer, and ``sout`` (10,): the numbers of
:func:`redservo.kernels.safety.apply_safety` (non-finite count, scale, over-velocity,
dropped, shield change, shield acted, acceleration excess, exceeded), the law's raw
``|q̇|∞`` and the distance past a hard limit no command could avoid (0: none).
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
from redservo.kernels.laws import classical, gpm, gpm_auto, new_outputs
from redservo.kernels.projection import large_projection
from redservo.kernels.safety import apply_safety
from redservo.kernels.sns import sns

__all__ = ["I_SNS_BAD", "LAW_IDS", "law_step", "step_events"]

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
NS = 10
I_SNS_RESTORED, I_SNS_BAD, F_SNS_SCALE = 5, 6, 2
"""Where :func:`law_step` packs ``sns``'s restored flag, infeasible joint and task scale."""


@kernel
def _raw_law(
    law_id: int,
    fopt: Any,
    iopt: Any,
    vopt: Any,
    J1: Any,
    e1: Any,
    e: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    prev: Any,
    has_prev: bool,
    hist: Any,
    has_hist: bool,
) -> Any:
    rc = fopt[0]
    rb = fopt[1]
    if law_id == 0:
        return classical(J1, e, lam, sec, has_sec, rc, rb)
    if law_id == 1:
        return gpm(J1, e, q, lp, lam, sec, has_sec, fopt[2], rc, rb)
    if law_id == 2:
        return gpm_auto(
            J1, e, q, lp, lam, dt, sec, has_sec, fopt[2], iopt[2] != 0, rc, rb, iopt[3] != 0
        )
    if law_id >= 3 and law_id <= 6:
        return iterative(
            J1,
            e,
            q,
            lp,
            lam,
            dt,
            sec,
            has_sec,
            iopt[2] != 0,
            fopt[2],
            iopt[3],
            rc,
            rb,
            fopt[3],
            fopt[4],
        )
    if law_id == 7:
        return directional(
            J1,
            e1,
            e,
            ff,
            has_ff,
            q,
            lp,
            lam,
            dt,
            sec,
            has_sec,
            fopt[2],
            iopt[2] != 0,
            fopt[3],
            rc,
            rb,
        )
    if law_id == 8:
        return wln(J1, e, q, lp, lam, sec, has_sec, iopt[2] != 0, hist, has_hist, rc, rb, 1e-9)
    if law_id == 9:
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
            vopt[0],
            iopt[2] != 0,
            vopt[1],
            iopt[3] != 0,
            fopt[2],
            rc,
            iopt[0] != 0,
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
    return large_projection(
        J1,
        e1,
        e,
        q,
        lp,
        lam,
        sec,
        has_sec,
        fopt[2],
        fopt[3],
        iopt[2],
        fopt[4],
        fopt[5],
        fopt[6],
        rc,
        rb,
        fopt[7],
    )


@kernel
def law_step(
    law_id: int,
    fopt: Any,
    iopt: Any,
    vopt: Any,
    J1: Any,
    e1: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    lam: float,
    dt: float,
    sec: Any,
    has_sec: bool,
    prev: Any,
    has_prev: bool,
    hist: Any,
    has_hist: bool,
) -> Any:
    """One law call and its safety layer on plain arrays (module docstring)."""
    m = e1.shape[0]
    e = np.empty(m)
    for i in range(m):
        e[i] = e1[i] + ff[i] / lam if has_ff else e1[i]  # effective error, CM01 eq. 2
    qdot, iout, fout, axes, axf, vec = _raw_law(
        law_id, fopt, iopt, vopt, J1, e1, e, ff, has_ff, q, lp, has_v, has_a, lam, dt,
        sec, has_sec, prev, has_prev, hist, has_hist,
    )  # fmt: skip
    task = qdot
    first = iopt[1] != 0
    if first:
        task = classical(J1, e, lam, sec, False, fopt[0], fopt[1])[0]
    out, bad, s, over_v, dropped, change, acted, worst, exceeded, past, _ = apply_safety(
        qdot, q, lp, has_v, has_a, dt, prev, has_prev, iopt[0] != 0, task, first
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
    return out, iout, fout, axes, axf, vec, sout


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
    :func:`law_step`: its law's events (the kernel of :mod:`redservo.kernels.events` the law
    object calls) and the safety layer's."""
    n = axes.shape[0]
    rb = fopt[1]
    if law_id == 0:
        mask = classical_events(m, n, iout, rb)[0]
    elif law_id == 1:
        mask = gpm_events(m, n, iout, rb)[0]
    elif law_id == 2:
        mask = gpm_auto_events(m, n, iout, axf, rb, fopt[2])[0]
    elif law_id >= 3 and law_id <= 6:
        mask = iterative_events(m, n, iout, fout, vec, rb, fopt[4])[0]
    elif law_id == 7:
        mask = directional_events(m, n, iout, rb)[0]
    elif law_id == 8:
        mask = wln_events(m, n, iout, rb)[0]
    elif law_id == 9:
        restored = iout[I_SNS_RESTORED] != 0
        mask = sns_events(m, iout[0], fout[F_SNS_SCALE], restored)[0]
    else:
        mask = large_projection_events(m, n, iout, axes, rb, fopt[7])[0]
    safe = safety_events(
        int(sout[0]), sout[1], sout[2] != 0, sout[3] != 0, sout[4], sout[5] != 0, sout[6],
        sout[7] != 0, sout[9],
    )  # fmt: skip
    return mask | safe[0]
