"""One iteration of a closed loop with an ideal sensor in compiled code: sense, then the step kernel.

:func:`sense` gives the robot's kinematics (:func:`redservo.kernels.robot.robot_kinematics`),
the features of an ideal sensor and their interaction matrix
(:mod:`redservo.kernels.loop_task`), ``e1`` and ``J1`` (CM01 eq. 25, the step kernel's
:func:`~redservo.kernels.control.task_rows`) and the known feed-forward; :func:`law_bits`
(:func:`law_bits_sec` with a secondary) runs the step kernel's law part (:func:`~redservo.kernels.control.law_core`) and reduces
its typed events to a bit mask; :func:`qp_step` is the ``qp`` law's step with its compiled
solver (:mod:`redservo.kernels.boxqp`), its secondary and its velocity-damper rows
(:mod:`redservo.kernels.loop_rows`), :func:`qp_law` the same without them.
The campaign loop (:func:`redservo.campaign.loop_kernel.closed_loop`) calls them at every
iteration (the benchmarks time that iteration at one configuration,
:mod:`redservo.bench.sensed`). Packs as :mod:`redservo.campaign.loop_kernel` documents them.
Units: m, rad, s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.bls import bls_reduce
from redservo.kernels.boxqp import SOLVED, qp_solve_reduced
from redservo.kernels.control import law_core, task_rows
from redservo.kernels.events import qp_events, safety_events
from redservo.kernels.loop_rows import qp_row_step
from redservo.kernels.loop_task import all_finite, known_feedforward, loop_task
from redservo.kernels.qp import qp_finish, qp_prepare
from redservo.kernels.robot import robot_kinematics
from redservo.kernels.safety import apply_safety
from redservo.kernels.step import I_SNS_BAD, LAW_IDS

__all__ = [
    "ABORT_INFEASIBLE",
    "ABORT_NON_FINITE",
    "ABORT_RAISES",
    "MAX_ITERATIONS",
    "QP",
    "TARGET_LOST",
    "law_bits",
    "law_bits_sec",
    "qp_law",
    "qp_step",
    "sense",
]

MAX_ITERATIONS, TARGET_LOST = 0, 3
"""The outcome codes :func:`sense` may end a run with (the loop's codes)."""
ABORT_NON_FINITE, ABORT_INFEASIBLE, ABORT_RAISES = 1, 2, 3
"""Why a run left the kernel early: the law would raise (ShapeError, InfeasibleError), or
the object path would (a feature invalid where the feed-forward measures it)."""

QP = -1
"""The law id of ``qp`` here (:data:`redservo.kernels.step.LAW_IDS` has no ``qp``)."""
_SNS = LAW_IDS["sns"]


@kernel
def qp_law(
    J1: Any,
    e1: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    prev: Any,
    law: Any,
    limits: Any,
    sim: Any,
    solve: Any,
) -> Any:
    """:func:`qp_step` without a secondary or rows: ``(q̇, bits, need_solve)``; a step the
    kernel cannot finish puts ``J1``, ``e1`` and ``ff`` into ``solve`` (its first five
    entries, :mod:`redservo.campaign.loop_kernel`) for Python."""
    none, G = np.zeros(0), np.zeros((0, q.shape[0]))
    qd, bits, need = qp_step(J1, e1, ff, has_ff, q, prev, law, limits, sim, none, G, none)
    if need:
        pJ, pe, pend, pf = solve[0], solve[1], solve[3], solve[4]
        pJ[:, :] = J1
        pe[:] = e1
        pf[:] = ff
        pend[3] = 1 if has_ff else 0
    return qd, bits, need


@kernel
def qp_step(
    J1: Any,
    e1: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    prev: Any,
    law: Any,
    limits: Any,
    sim: Any,
    sec: Any,
    G: Any,
    b: Any,
) -> Any:
    """The ``qp`` law (redundancy/qp.py) and its safety layer: ``(q̇, bits, need_solve)``.

    The law's kernels on the effective error ``e1 + ff / λ`` and the secondary ``sec`` (n,),
    or none when empty: :func:`~redservo.kernels.qp.qp_prepare`, then where the
    unconstrained optimum lies within the bounds ``qp_finish``, elsewhere the compiled
    solver (:func:`~redservo.kernels.boxqp.qp_solve_reduced` on the problem
    :func:`~redservo.kernels.qp.qp_setup` reduces, when ``iopt[1]``: the law's solver is
    ``"auto"``/``"active-set"``), then the safety layer. A step the kernel cannot finish
    returns ``need_solve`` (the caller hands it to Python, which calls the law itself):
    another solver chosen, or the compiled one failed (the law's Python fallback). Damper
    rows ``G q̇ ≥ b`` (r, n), (r,) that the unconstrained optimum does not meet are solved
    here, as the law does (:func:`redservo.kernels.rowqp.qp_rows`; infeasible even relaxed,
    or failed: dropped, the failure flagged ``solver-fallback``).
    """
    _, fopt, iopt, vopt, _ = law
    lp, has_v, has_a, _, _ = limits
    lam, dt = sim[0], sim[1]
    m, n = J1.shape
    e = np.empty(m)
    for i in range(m):
        e[i] = e1[i] + ff[i] / lam if has_ff else e1[i]  # LawInputs.e_eff
    zn = np.zeros(n)
    has_sec = sec.shape[0] > 0
    z = sec if has_sec else zn
    shield, has_vopt = iopt[0] != 0, iopt[2] != 0
    rates = (q, lp, has_v, has_a, dt, prev, True, z, has_sec, lam)
    x, inside, lo, hi, conflicts, xdot, rank, smax = qp_prepare(
        J1, e, *rates, fopt[2], fopt[3], vopt[0], has_vopt, fopt[0], shield
    )
    eps_abs = fopt[1] * smax * smax if smax > 0.0 else fopt[1]
    fixed, resid, rowed, fallback = qp_row_step(
        J1, xdot, lo, hi, eps_abs, z, has_sec, G, b, inside, x, q, dt, lp
    )
    if rowed:
        pass
    elif inside:
        fixed = qp_finish(J1, xdot, lo, hi, x, q, dt, lp)[0]
    else:
        status = SOLVED - 1
        if iopt[1] != 0:  # qp_setup's reduction, the law's _solve
            xr, free, _, _, _, lof, hif, P, c = bls_reduce(J1, xdot, lo, hi, z, eps_abs)
            sol = (xr, free, P, c, lof, hif, z, has_sec, q, dt, lp)
            fixed, _, _, resid, status = qp_solve_reduced(J1, xdot, lo, hi, *sol)
        if status != SOLVED:
            return x, 0, True
    bits = qp_events(m, rank, conflicts, fallback, resid)[0]
    qd, bad, s, over_v, dropped, change, acted, worst, exc, past, _ = apply_safety(
        fixed, q, lp, has_v, has_a, dt, prev, True, shield, zn, False
    )
    safe = safety_events(bad, s, over_v, dropped, change, acted, worst, exc, past)
    return qd, bits | safe[0], False


@kernel
def law_bits(
    J1: Any,
    e1: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    prev: Any,
    hist: Any,
    has_hist: bool,
    law: Any,
    limits: Any,
    sim: Any,
) -> Any:
    """:func:`law_bits_sec` without a secondary."""
    return law_bits_sec(J1, e1, ff, has_ff, q, prev, hist, has_hist, law, limits, sim, q[:0])


@kernel
def law_bits_sec(
    J1: Any,
    e1: Any,
    ff: Any,
    has_ff: bool,
    q: Any,
    prev: Any,
    hist: Any,
    has_hist: bool,
    law: Any,
    limits: Any,
    sim: Any,
    sec: Any,
) -> Any:
    """Step 4 for a law of ``law_step``: the step kernel's law part
    (:func:`redservo.kernels.control.law_core`, feed-forward ``ff`` when ``has_ff``, the
    secondary ``sec`` (n,) or empty: none): ``(q̇, bits, abs_grad, abort)``."""
    law_id, fopt, iopt, vopt, _ = law
    lp, has_v, has_a, _, _ = limits
    none = q[:0]
    inputs = (ff if has_ff else e1[:0], sec, prev, hist if has_hist else none)
    packs = ((law_id, fopt, iopt, vopt), (lp, has_v, has_a), (sim[0], sim[1]))
    ok, out, lev, sev = law_core(q, J1, e1, *packs, inputs)
    if not ok:
        return none, 0, none, ABORT_NON_FINITE
    qd, iout, _, _, axf, _, _ = out
    if law_id == _SNS and iout[I_SNS_BAD] >= 0:
        return qd, 0, axf, ABORT_INFEASIBLE
    return qd, lev[0] | sev[0], axf, 0


@kernel
def sense(it: int, q: Any, robot: Any, scene: Any, task: Any, sim: Any) -> Any:
    """Steps 1-3 and the feed-forward: ``(J, e1, J1, ff, has_ff, outcome, abort)``,
    ``outcome`` -1 while the run goes on."""
    dt = sim[1]
    t = it * dt
    bMc, J = robot_kinematics(q, robot)
    e, L, cMw, lost = loop_task(bMc, scene, task, t)
    if lost:
        return J, e, L, e, False, TARGET_LOST, 0
    e1, J1 = task_rows(e, L, task[8], J)  # CM01 eq. 25, the step kernel's
    if not all_finite(J1, e1):
        return J, e1, J1, e1, False, MAX_ITERATIONS, ABORT_NON_FINITE
    if not np.isfinite(np.sum(J1) + np.sum(e1)):
        return J, e1, J1, e1, False, MAX_ITERATIONS, ABORT_NON_FINITE
    if not sim[6]:
        return J, e1, J1, e1, False, -1, 0
    ff, ok = known_feedforward(cMw, scene, task, t, dt)
    if not (ok and np.all(np.isfinite(ff))):
        return J, e1, J1, ff, True, MAX_ITERATIONS, ABORT_RAISES
    return J, e1, J1, ff, True, -1, 0
