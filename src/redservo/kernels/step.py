"""One law call and its safety layer in compiled code, the law chosen by an id.

:func:`law_step` (driven by the step kernel, :mod:`redservo.kernels.control`) is what a batched
closed loop calls for each sample (the simulator's ``simulate`` runs the same kernels one
object at a time). A law is selected by its id
(:data:`LAW_IDS`, generated from the laws' declarations with the dispatch
:func:`~redservo.kernels.law_dispatch.raw_law` and
:func:`~redservo.kernels.law_dispatch.law_events`, :mod:`redservo.kernels.law_dispatch`)
and its options are packed by :func:`redservo.redundancy.kio.law_options` into a float
array ``fopt`` and an int array ``iopt``; ``vopt`` (2, n) holds per-joint options
(``sns``'s ``v_max`` and ``a_max``, inf when absent). ``qp`` is not here: its solver is a Python
library (the law calls the kernels of :mod:`redservo.kernels.qp` around it).

Option layout: the slots each law's declaration numbers
(:func:`redservo.redundancy.options.slotted`; the common ones in
:mod:`redservo.kernels.lawopts`).

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
from redservo.kernels.events import safety_events
from redservo.kernels.law_dispatch import (
    F_SNS_SCALE,
    I_SNS_BAD,
    I_SNS_RESTORED,
    LAW_IDS,
    law_events,
    raw_law,
)
from redservo.kernels.lawopts import F_RCOND, F_ROBUST, I_FIRST, I_SHIELD
from redservo.kernels.laws import classical
from redservo.kernels.safety import apply_safety

__all__ = [
    "F_SNS_SCALE",
    "I_SNS_BAD",
    "I_SNS_RESTORED",
    "LAW_IDS",
    "law_events",
    "law_raw",
    "law_step",
    "sout_events",
    "step_events",
]

NS = 11
"""Length of the safety numbers ``sout`` of :func:`law_step`."""


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
    qdot, iout, fout, axes, axf, vec = raw_law(law, limits, gains, J1, e1, e, q, io)
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
    qdot, iout, fout, axes, axf, vec = raw_law(law, limits, gains, J1, e1, e, q, io)
    task = qdot
    first = iopt[I_FIRST] != 0
    if first:
        task = classical(J1, e, lam, sec, False, fopt[F_RCOND], fopt[F_ROBUST])[0]
    out, sout = safe_command(
        qdot, q, lp, has_v, has_a, dt, prev, has_prev, iopt[I_SHIELD] != 0, task, first
    )
    return out, iout, fout, axes, axf, vec, sout


@kernel
def safe_command(
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
    first: bool,
) -> Any:
    """The safety layer on the law's command ``qdot`` (n,) (:func:`redservo.kernels.safety.apply_safety`,
    docs/safety.md): ``(q̇, sout)``, ``sout`` (NS,) the numbers its events are worded from
    (:func:`sout_events`): the fault code, the uniform scale, the velocity excess, the
    dropped secondary, the change of command, whether the shield acted, the worst margin,
    an acceleration excess, the law's largest joint speed (rad/s or m/s), the crossing and
    its joint."""
    out, bad, s, over_v, dropped, change, acted, worst, exceeded, past, joint = apply_safety(
        qdot, q, lp, has_v, has_a, dt, prev, has_prev, shield, task, first
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
    return out, sout


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
