"""The closed loop of one campaign run as one compiled kernel (docs/scaling.md).

:func:`closed_loop` runs :func:`redservo.simulation.simulate` for the set-ups it covers
(:mod:`redservo.campaign.fastloop` checks them): an ideal sensor, point targets static or
on waypoints, image-point and moment features with the current depth, no actuator model,
no objective, no noise, a constant gain, no feed-forward or the known one, and a law with
a compiled step. It performs, at every iteration ``it`` (time ``t = it dt``), the very
operations of the object path, in the same order and with the same kernels:

1. ``bMc, J = kinematics(q)`` (the Afma6, a DH chain or a chain of fixed transforms and
   joint axes: a URDF robot);
2. ``cMo = (inverse(bMc) @ bMw) @ wMo(t)`` per target, the features measured and ``L``
   built by the kernels of the feature objects (:mod:`redservo.kernels.loop_task`; a
   feature that cannot be measured ends the run with ``target_lost``);
3. ``e1 = C (s - s*)``, ``J1 = (C L) J``; the image check of every target's points; the
   known feed-forward ``∂e1/∂t`` (:func:`~redservo.kernels.loop_task.known_feedforward`);
4. the law and its safety layer, :func:`redservo.kernels.step.law_step`; for ``qp`` its
   kernels and its compiled solver (:mod:`redservo.kernels.boxqp`); with collision
   avoidance on, the repulsive secondary and, for ``qp`` and ``sns``, the velocity-damper
   rows (:mod:`redservo.kernels.loop_rows`), solved by the compiled kernels the law
   objects call too. A step the kernel cannot finish (the law set to a Python solver
   library such as daqp, the compiled solver failing: the law's Python fallback) returns
   :data:`NEED_SOLVE`: Python calls the law itself (with the rows the loop built) and calls
   the loop again from that iteration with the command;
5. the actuator saturation, the camera twist ``J q̇``, ``‖e1‖``, the convergence test,
   the hard-limit test (``joint_limit``) and ``q ← clip(q + q̇ dt)``.

The small products that the object path leaves to numpy (``@`` on 4x4, (m, k) and
(k, 6) matrices, ``J q̇``, ``e1·e1``) are ``np.dot`` calls here: numba hands them to the
same BLAS routines, so every logged number is bit-for-bit the one of the object path
(tested on campaigns, tests/test_campaign_fast.py). The typed diagnostics of a step are
reduced to a bit mask of the flags raised (:func:`redservo.kernels.step.step_events`, the
flag rules the law objects use).

Outcome codes: :data:`MAX_ITERATIONS`, :data:`CONVERGED`, :data:`JOINT_LIMIT`,
:data:`TARGET_LOST` (and :data:`NEED_SOLVE`). A run the object path would end with an exception (non-finite
``J1``/``e1``, inconsistent ``sns`` bounds) returns an ``abort`` code instead, and the
caller runs it on the object path. Units: m, rad, s.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from redservo.kernels._jit import COMPILED, kernel
from redservo.kernels.loop_avoid import (
    COLLISION,
    collide_check,
    keep_measurement,
    secondary,
    shield_step,
)
from redservo.kernels.loop_rows import damper_rows, hand_back
from redservo.kernels.sensed import (
    ABORT_INFEASIBLE,
    ABORT_NON_FINITE,
    ABORT_RAISES,
    QP,
    law_bits_sec,
    qp_step,
    sense,
)
from redservo.kernels.sns_rows import sns_row_step
from redservo.kernels.step import LAW_IDS
from redservo.simulation.loop import LIMIT_TOLERANCE

__all__ = [
    "ABORT_INFEASIBLE",
    "ABORT_NON_FINITE",
    "ABORT_RAISES",
    "COLLISION",
    "CONVERGED",
    "JOINT_LIMIT",
    "MAX_ITERATIONS",
    "NEED_SOLVE",
    "QP",
    "TARGET_LOST",
    "closed_loop",
]

MAX_ITERATIONS, CONVERGED, JOINT_LIMIT, TARGET_LOST, NEED_SOLVE = 0, 1, 2, 3, 4
"""Outcome codes (``ABORT_*``: :mod:`redservo.kernels.sensed`; :data:`COLLISION` 5)."""
_WLN, _SNS = LAW_IDS["wln"], LAW_IDS["sns"]


@kernel
def _advance(
    it: int,
    q: Any,
    prev: Any,
    qd: Any,
    bits: int,
    J: Any,
    e1: Any,
    limits: Any,
    sim: Any,
    logs: Any,
) -> Any:
    """Step 5: saturate, log row ``it``, test convergence and the hard limits, move ``q``;
    ``(rows, outcome, limit_axis)``, ``outcome`` -1 while the run goes on."""
    _, _, _, q_min, q_max = limits
    dt, tol, stop, qsat, has_qsat = sim[1], sim[2], sim[3], sim[4], sim[5]
    Q, QD, TW, EN, FL = logs
    n = q.shape[0]
    max_it = Q.shape[0]
    if has_qsat:
        ratio = np.max(np.abs(qd) / qsat)
        if ratio > 1.0:
            qd = qd / ratio
    Q[it] = q
    QD[it] = qd
    TW[it] = np.dot(J, qd)
    err = np.sqrt(np.dot(e1, e1))
    EN[it] = err
    FL[it] = bits
    if err < tol and (stop or it == max_it - 1):
        return it + 1, CONVERGED, -1
    q_next = q + qd * dt
    for i in range(n):
        if q_next[i] < q_min[i] - LIMIT_TOLERANCE or q_next[i] > q_max[i] + LIMIT_TOLERANCE:
            return it + 1, JOINT_LIMIT, i
    prev[:] = qd
    for i in range(n):  # np.clip: min(max(x, lo), hi)
        v = q_next[i] if q_next[i] > q_min[i] else q_min[i]
        q[i] = v if v < q_max[i] else q_max[i]
    return it + 1, -1, -1


@kernel
def closed_loop(
    q: Any,
    prev: Any,
    robot: Any,
    scene: Any,
    task: Any,
    law: Any,
    limits: Any,
    sim: Any,
    logs: Any,
    solve: Any,
    coll: Any,
) -> Any:
    """Run the closed loop from ``q`` (module docstring), from iteration ``solve[3][2]``.

    Args (tuples of arrays and numbers, packed by :mod:`redservo.campaign.fastloop`):
        q, prev: (n,) joints and previous command; updated in place (the state of a run
            resumed after a ``qp`` solve).
        robot: ``(kind, eMc, cVe, coupling, offset, par, base, flange, standard, frames,
            joints)``, kind 0 the Afma6, 1 a DH chain, 2 a chain of fixed transforms and axes
            (a URDF robot: :mod:`redservo.kernels.chain`).
        scene, task: the packs of :mod:`redservo.kernels.loop_task` (targets, static or on
            waypoints; image points and moment features).
        law: ``(law_id, fopt, iopt, vopt, has_cap)``: :func:`redservo.redundancy.kio.law_options`,
            or :data:`QP` with ``fopt = (rcond, eps, k_p, margin)``, ``iopt = (shield,
            solver in the kernel, has v_max)``, ``vopt[0] = v_max``.
        limits: ``(lp, has_v, has_a, q_min, q_max)``.
        sim: ``(lam, dt, tolerance, stop_at_convergence, qsat (n,), has_qsat, known_ff)``.
        logs: ``(Q, QD, TW, EN, FL)``, (N, n), (N, n), (N, 6), (N,), (N,) int64; N is the
            iteration cap.
        solve: ``(J1, e1, q̇, pend, ff, secondary, G, b, pairs)``: a ``qp`` or ``sns`` step
            for Python and the command it got (:func:`~redservo.kernels.loop_rows.hand_back`);
            ``pend`` = (command given, its flag bits, first iteration, has ff, number of
            damper rows, has secondary); ``G`` (P, n), ``b`` (P,), ``pairs`` (P,) int64 hold
            the step's damper rows in their first rows.
        coll: the obstacles' pack (:mod:`redservo.kernels.loop_avoid`): the pairs measured
            before sensing (outcome :data:`COLLISION` on a contact), the repulsive
            secondary, the distance shield after the law.

    Returns:
        ``(rows, outcome, limit_axis, abort)``; outcome :data:`NEED_SOLVE` asks for a solve.
    """
    law_id, iopt = law[0], law[2]
    n = q.shape[0]
    max_it = logs[0].shape[0]
    hist = np.zeros(n)
    has_hist = False
    history = law_id == _WLN and iopt[2] != 0
    start = solve[3][2]
    dd, Jd = np.zeros(0), np.zeros((0, n))
    for it in range(start, max_it):
        if coll[0]:  # a resumed iteration was tallied before its solve
            dd, Jd, hit = collide_check(it, q, coll, it != start or solve[3][0] == 0)
            if hit:
                return it, COLLISION, -1, 0
        J, e1, J1, ff, has_ff, outcome, abort = sense(it, q, robot, scene, task, sim)
        if outcome >= 0:
            return it, outcome, -1, abort
        if it == start and solve[3][0] != 0:  # resumed: the law's command, from Python
            qd, bits = solve[2].copy(), solve[3][1]
            solve[3][0] = 0
        else:
            sec, drows = secondary(dd, Jd, coll), damper_rows(dd, Jd, coll)
            args = (J1, e1, ff, has_ff, q, prev, hist, has_hist, law, limits, sim, sec, drows)
            qd, bits, axf, code = _law(*args)
            if code == NEED_SOLVE:
                hand_back(solve, J1, e1, ff, has_ff, sec, drows, it)
                keep_measurement(q, dd, Jd, coll)
                return it, NEED_SOLVE, -1, 0
            if code != 0:
                return it, MAX_ITERATIONS, -1, code
            if history:
                hist = axf
                has_hist = True
        qd, bits = shield_step(q, qd, bits, prev, dd, Jd, coll)
        rows, outcome, axis = _advance(it, q, prev, qd, bits, J, e1, limits, sim, logs)
        if outcome >= 0:
            return rows, outcome, axis, 0
    return max_it, MAX_ITERATIONS, -1, 0


@kernel
def _law(
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
    rows: Any,
) -> Any:
    """Step 4: ``(q̇, bits, abs_grad, code)``, ``code`` 0, an ``ABORT_*`` code or
    :data:`NEED_SOLVE`: the step goes to Python (``qp`` with a Python solver library, or
    its compiled solver failed). The damper rows are solved here, by the kernels the law
    objects call: ``qp``'s in :func:`~redservo.kernels.sensed.qp_step`, ``sns``'s in
    :func:`~redservo.kernels.sns_rows.sns_row_step` (:mod:`redservo.kernels.loop_rows`).

    Its arguments are named, not ``*args``: numba types a star parameter as a
    ``StarArgTuple`` in a compiled caller and as a ``Tuple`` in a Python one, two versions
    of a kernel that links every law (the loop's body run as plain Python compiled it again)."""
    G, b, _ = rows
    if law[0] == QP:
        qd, bits, need = qp_step(J1, e1, ff, has_ff, q, prev, law, limits, sim, sec, G, b)
        return qd, bits, q[:0], NEED_SOLVE if need else 0
    step = (J1, e1, ff, has_ff, q, prev, hist, has_hist, law, limits, sim, sec)
    qd, bits, axf, abort = law_bits_sec(*step)
    if abort == 0 and law[0] == _SNS and b.shape[0] > 0:
        ctx = (prev, sec, law, limits, sim, G, b)
        qr, rbits, replaced = sns_row_step(qd, J1, e1, ff, has_ff, q, *ctx)
        if replaced:
            return qr, rbits, axf, 0
    return qd, bits, axf, abort


def _stamp_with_sources(*dispatchers: Any) -> None:
    """Make the on-disk cache of these kernels depend on every source they compile in.

    numba's ``cache=True`` checks only the file of the function itself, while a compiled
    caller embeds its callees: after an edit of :mod:`redservo.kernels` the cached loop
    would run the old kernels. The cache index stamp becomes ``(numba's stamp, SHA-256 of
    the sources)``, so any edit recompiles the loop. Relies on numba internals; if they
    change, numba's own stamp is kept.
    """
    if not COMPILED:
        return
    src = Path(__file__).resolve().parents[1]
    files = [
        *sorted((src / "kernels").glob("*.py")),
        *sorted((src / "redundancy").glob("*.py")),  # constants compiled in
        Path(__file__).resolve(),
        src / "simulation" / "loop.py",
    ]
    digest = hashlib.sha256(b"".join(p.read_bytes() for p in files)).hexdigest()
    for dispatcher in dispatchers:
        try:
            cache_file = dispatcher._cache._cache_file
            cache_file._source_stamp = (cache_file._source_stamp, digest)
        except AttributeError:  # pragma: no cover - another numba layout
            pass


_stamp_with_sources(_advance, _law, closed_loop)
