"""The ``qp`` law's Controller step in one compiled call (its compiled box QP inside).

``qp`` is not a law of the step kernel's dispatch (:data:`redservo.kernels.step.LAW_IDS`:
its law object may call a Python solver library). With its compiled solver
(:mod:`redservo.kernels.boxqp`, ``solver="auto"``/``"active-set"``) and no distance rows, its
step needs no Python, and :func:`qp_measured_control` / :func:`qp_robot_control` run it as
:func:`redservo.kernels.control.measured_control` / ``robot_control`` run the other laws,
with the same packs and the same buffer (:func:`~redservo.kernels.control.control_layout`):
``L(s, 1/Ẑ)``, ``e``, CM01 eq. 25 (:func:`~redservo.kernels.control.task_rows`), the input
check, then the very kernels the law object calls in its ``compute``
(:func:`~redservo.kernels.qp.qp_setup`, :func:`~redservo.kernels.qp.qp_finish` or
:func:`~redservo.kernels.boxqp.qp_solve_reduced`, :func:`~redservo.kernels.events.qp_events`)
and the safety layer of every law (:func:`~redservo.kernels.safety.apply_safety`, its numbers
``sout`` as :func:`~redservo.kernels.step.law_step` lays them out). The law's
``diagnose`` (redundancy/qp.py) turns the buffer into its diagnostics.

A step the kernel cannot finish (an input the check rejects, or the compiled solver failed:
the law's fallback is scipy's) returns a law mask of -1: the caller then takes the object
path, which computes the whole step (and raises the error naming a bad input).

Packs: ``law`` ``(law_id, fopt, iopt, vopt)`` with ``fopt = (rcond, eps, k_p, margin)``,
``iopt = (shield, 1, has v_max)``, ``vopt[0]`` the law's ``v_max`` per joint
(:func:`redservo.redundancy.qp.qp_pack`); the law's outputs in the buffer: ``iout[0]`` the
rank of ``J1``, ``iout[1]`` the solver (:data:`NO_SOLVER`, :data:`SOLVED_PLAIN`,
:data:`SOLVED_POLISHED`), ``iout[2]`` 1 with a secondary command; ``fout[0]`` the relative
task residual (-1: not computed); ``axes`` the joints at a bound (1.0) when the solver ran;
``vec`` the joints whose bounds conflict (1.0). Units: rad or m, s, 1/s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.boxqp import SOLVED, qp_solve_reduced
from redservo.kernels.control import NF, NI, _put_law, points_rows, put_task
from redservo.kernels.events import qp_events
from redservo.kernels.inputs import inputs_ok
from redservo.kernels.qp import qp_finish, qp_setup
from redservo.kernels.robot import robot_kinematics
from redservo.kernels.step import safe_command, sout_events

__all__ = [
    "NO_SOLVER",
    "SOLVED_PLAIN",
    "SOLVED_POLISHED",
    "qp_core",
    "qp_measured_control",
    "qp_robot_control",
]

NO_SOLVER, SOLVED_PLAIN, SOLVED_POLISHED = 0, 1, 2
"""``iout[1]``: the unconstrained optimum was within the bounds (no solver), the compiled
solver's solution, the same polished on its active set."""


@kernel
def _safe(
    qdot: Any, q: Any, limits: Any, dt: float, prev: Any, has_prev: bool, shield: bool
) -> Any:
    """The safety layer on the law's command: ``(q̇, sout)``, ``sout`` (NS,) as
    :func:`redservo.kernels.step.law_step` lays it out (uniform scaling)."""
    lp, has_v, has_a = limits
    return safe_command(qdot, q, lp, has_v, has_a, dt, prev, has_prev, shield, qdot, False)


@kernel
def qp_core(q: Any, J1: Any, e1: Any, law: Any, limits: Any, gains: Any, inputs: Any) -> Any:
    """The input check, the ``qp`` law (redundancy/qp.py, ``compute`` with its compiled
    solver) and the safety layer on ``J1`` (m, n) and ``e1`` (m,); arguments as
    :func:`redservo.kernels.control.law_core`, ``inputs`` ``(ff, sec, prev)``.

    Returns:
        ``(status, (q̇, iout, fout, axes, axf, vec, sout), (lmask, lvals, lsrc), (smask,
        svals, ssrc))`` as ``law_core``'s, ``status`` 1 when done, 0 when an input fails the
        check, -1 when the compiled solver failed (the object path then takes the law's
        fallback); the other outputs are then empty.
    """
    ff, sec, prev = inputs
    m, n = J1.shape
    z, zi = e1[:0], np.zeros(0, dtype=np.int64)
    empty = (z, zi, z, z, z, z, z)
    if not inputs_ok(J1, e1, q, limits[0], ff, sec, prev):
        return 0, empty, (0, z, zi), (0, z, zi)
    lam, dt = gains
    _, fopt, iopt, vopt = law
    lp, has_v, has_a = limits
    has_ff, has_sec, has_prev = ff.shape[0] > 0, sec.shape[0] > 0, prev.shape[0] > 0
    e = np.empty(m)
    for i in range(m):
        e[i] = e1[i] + ff[i] / lam if has_ff else e1[i]  # LawInputs.e_eff, CM01 eq. 2
    zn = np.zeros(n)
    s_in = sec if has_sec else zn
    p_in = prev if has_prev else zn
    shield, has_vopt = iopt[0] != 0, iopt[2] != 0
    rates = (q, lp, has_v, has_a, dt, p_in, has_prev, s_in, has_sec, lam)
    opts = (fopt[2], fopt[3], vopt[0], has_vopt, fopt[0], fopt[1], shield)
    out = qp_setup(J1, e, *rates, *opts)
    qstar, inside, lo, hi, conflicts, xdot, rank, _, xfix, free, P, c, lof, hif = out
    iout = np.zeros(NI, dtype=np.int64)
    fout = np.zeros(NF)
    axes = np.zeros(n)
    if inside:
        fixed = qp_finish(J1, xdot, lo, hi, qstar, q, dt, lp)[0]
        resid = -1.0
    else:
        sol = (xfix, free, P, c, lof, hif, s_in, has_sec, q, dt, lp)
        fixed, polished, active, resid, solved = qp_solve_reduced(J1, xdot, lo, hi, *sol)
        if solved != SOLVED:
            return -1, empty, (0, z, zi), (0, z, zi)
        iout[1] = SOLVED_POLISHED if polished else SOLVED_PLAIN
        for i in range(n):
            axes[i] = 1.0 if active[i] else 0.0
    iout[0] = rank
    iout[2] = 1 if has_sec else 0
    fout[0] = resid
    vec = np.zeros(n)
    for i in range(n):
        vec[i] = 1.0 if conflicts[i] else 0.0
    lev = qp_events(m, rank, conflicts, False, resid)
    qdot, sout = _safe(fixed, q, limits, dt, p_in, has_prev, shield)
    return 1, (qdot, iout, fout, axes, zn, vec, sout), lev, sout_events(sout)


@kernel
def qp_measured_control(
    q: Any,
    J: Any,
    meas: Any,
    law: Any,
    limits: Any,
    gains: Any,
    inputs: Any,
    buf: Any,
) -> Any:
    """:func:`redservo.kernels.control.measured_control` with the ``qp`` law
    (:func:`qp_core`): ``(law mask, safety mask, vec)``, a law mask of -1 when the object
    path must take the step (module docstring)."""
    s, iz, s_star, C = meas
    e, e1, L, J1 = points_rows(s, iz, s_star, C, J)
    status, out, lev, sev = qp_core(q, J1, e1, law, limits, gains, inputs)
    if status != 1:
        return -1, 0, e[:0]
    put_task(buf, _put_law(buf, out, lev, sev), e, e1, J1, L, q)
    return lev[0], sev[0], out[5]


@kernel
def qp_robot_control(q: Any, robot: Any, *packs: Any) -> Any:
    """:func:`qp_measured_control` on a robot with compiled kinematics (``robot``: the pack
    of :mod:`redservo.robots.pack`); ``packs`` as
    :func:`redservo.kernels.control.robot_control`'s."""
    _, J = robot_kinematics(q, robot)
    return qp_measured_control(q, J, *packs)
