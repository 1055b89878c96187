"""The steps the compiled campaign loop hands back to Python, computed by the law itself.

:func:`redservo.campaign.loop_kernel.closed_loop` returns ``NEED_SOLVE`` for a step it
cannot finish: a ``qp`` step whose solver is a Python library (or whose compiled solver
failed). (The velocity-damper rows of ``qp`` and ``sns`` are solved in the loop by the
kernels the laws call, :mod:`redservo.kernels.loop_rows`.) :func:`python_step` then calls the law
with what the object path's Controller gives it (the step's ``J1``, ``e1``, ``q``, the
previous command, the known feed-forward, the repulsive secondary) and the rows the loop
built (:func:`~redservo.redundancy.distance_rows.given_rows`), and puts its command and flag
bits into the loop's ``solve`` pack, from which the loop resumes. Units: rad, m, s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.experiment.build import Experiment
from redservo.redundancy import Law
from redservo.redundancy.distance_rows import DistanceRows, given_rows
from redservo.redundancy.flags import FLAGS

__all__ = ["python_step", "solve_pack"]


def solve_pack(exp: Experiment, coll: tuple[Any, ...]) -> tuple[Any, ...]:
    """The loop's ``solve`` pack for ``exp`` (:func:`~redservo.campaign.loop_kernel.closed_loop`),
    room for a row per pair of the collision pack ``coll``."""
    m, n, P = exp.task.m, exp.robot.n, coll[10].shape[0]
    pend = np.zeros(6, dtype=np.int64)
    step = (np.zeros((m, n)), np.zeros(m), np.zeros(n), pend, np.zeros(m))
    return (*step, np.zeros(n), np.zeros((P, n)), np.zeros(P), np.zeros(P, dtype=np.int64))


def _rows(exp: Experiment, r: int, solve: tuple[Any, ...]) -> DistanceRows | None:
    """The damper rows the loop handed over (None: none)."""
    if r == 0:
        return None
    c = exp.options.collision
    geo = None if c is None else c.compiled(exp.robot)
    assert geo is not None  # rows come from the compiled geometry's pairs
    G, b, pairs = solve[6][:r].copy(), solve[7][:r].copy(), solve[8][:r]
    return DistanceRows(G, b, tuple(geo.names[int(p)] for p in pairs))


def python_step(
    exp: Experiment, law: Law, q: Any, prev: Any, sim: tuple[Any, ...], solve: tuple[Any, ...]
) -> None:
    """The handed-back step computed by ``law`` (module docstring), its command and flag
    bits written into ``solve`` for the loop to resume with."""
    pJ, pe, px, pend, pf, ps = solve[:6]
    with given_rows(law, _rows(exp, int(pend[4]), solve)):
        res = law(
            J1=pJ.copy(),
            e1=pe.copy(),
            q=q.copy(),
            limits=exp.limits,
            lam=sim[0],
            dt=sim[1],
            qdot_prev=prev.copy(),
            de1_dt=pf.copy() if pend[3] else None,
            secondary=ps.copy() if pend[5] else None,
        )
    px[:] = res.qdot
    pend[0] = 1
    pend[1] = flag_bits(res.diagnostics.events)


def flag_bits(events: Any) -> int:
    """The loop's bit mask (bit ``j`` is ``FLAGS[j]``) of a law's typed events."""
    bits = 0
    for ev in events:
        bits |= 1 << FLAGS.index(ev.flag)
    return bits
