"""Collision avoidance in the compiled campaign loop: the object path's steps, in compiled code.

At every iteration of :func:`redservo.campaign.loop_kernel.closed_loop` with a collision
pack ``coll`` on (packed by :mod:`redservo.campaign.loop_avoid`), in the object path's order
(:mod:`redservo.simulation.loop`, :mod:`redservo.control.output`):

1. :func:`collide_check` before sensing: the pairs at the true ``q`` that can matter
   (:func:`~redservo.kernels.loop_cull.measure_culled`: the kernel the
   :class:`~redservo.control.avoidance.Collision` of the object path measures with, minus
   the pairs whose lower bound proves them irrelevant; the same records bit for bit), the
   smallest distance and its pair logged, the distances tallied per pair kind; a distance
   <= 0 ends the run with ``collision``;
2. :func:`secondary`: the repulsive joint velocity (:func:`~redservo.kernels.loop_collide.repulsive`)
   as the law's ``secondary``, when avoidance is on and the law takes one;
3. :func:`shield_step` after the law: the skipped pairs the command could bring near
   (:func:`~redservo.kernels.loop_cull.fill_for_shield`), then the distance shield and its
   check on the true geometry (:func:`~redservo.kernels.loop_collide.shield_scale`,
   :func:`~redservo.kernels.loop_cull.exact_scale`), flagged ``distance-shield-acted``
   and, when the scaling breaks ``q̈_max``, ``acceleration-exceeded``.

Pack ``coll``: ``(on, arm, geom, fopt, iopt, qddot_max (n,), MD (N,), CP (N,) int64,
tally (3,), contact (3,), kinds (P,) int64, cache, scratch)``, ``cache = (q (n,), d (P,),
J (P, n), valid (1,), lb (P,), O (F, 3), JO (F, 3, n))`` the shield check's last measurement
with its bounds and frames, which step 1 of the next iteration reuses when it was taken at
the very ``q`` reached (the shield left the command alone: the same numbers, one query
fewer); ``fopt = (d_safe, d_influence, xi, damping,
dt)``; ``iopt = (repel, law takes a secondary, shield, shield bit, acceleration bit, has
q̈_max, the law solves with damper rows)`` (the last: :mod:`redservo.kernels.loop_rows`); ``tally = (min environment, min self, steps within d_influence)`` (inf: none);
``contact = (pair, distance, iteration)``, pair -1 without contact; ``kinds`` 0 environment,
1 self; ``scratch = (lb (P,), O (F, 3), JO (F, 3, n))`` step 1's lower bounds and frame
origins, for step 3. Units: m, rad, s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.loop_collide import repulsive, shield_scale
from redservo.kernels.loop_cull import exact_scale, fill_for_shield, measure_culled

__all__ = ["COLLISION", "collide_check", "keep_measurement", "secondary", "shield_step"]

COLLISION = 5
"""The loop's outcome code of a run ended by a contact (:mod:`redservo.campaign.loop_kernel`)."""


@kernel
def collide_check(it: int, q: Any, coll: Any, tally: bool) -> Any:
    """Step 1: ``(d (P,), J_d (P, n), contact)``; the step is tallied unless ``tally`` is
    False (an iteration resumed after a Python solve was tallied before)."""
    _, arm, geom, fopt, _, _, MD, CP, tl, contact, kinds, cache, scratch = coll
    qc, dc, Jc, valid, lbc, Oc, JOc = cache
    if valid[0] != 0 and np.all(qc == q):  # measured there by the last step's shield check
        d, J = dc.copy(), Jc.copy()
        scratch[0][:], scratch[1][:, :], scratch[2][:, :, :] = lbc, Oc, JOc
    else:
        d, J, lb, O, JO = measure_culled(q, arm, geom, fopt[1])
        scratch[0][:], scratch[1][:, :], scratch[2][:, :, :] = lb, O, JO
    valid[0] = 0
    if d.shape[0] == 0:
        return d, J, False
    k = np.argmin(d)
    MD[it] = d[k]
    CP[it] = k
    if tally:
        for p in range(d.shape[0]):
            if d[p] < tl[kinds[p]]:
                tl[kinds[p]] = d[p]
        if d[k] < fopt[1]:
            tl[2] += 1.0
    if d[k] <= 0.0:
        contact[0], contact[1], contact[2] = k, d[k], it
        return d, J, True
    return d, J, False


@kernel
def secondary(d: Any, J: Any, coll: Any) -> Any:
    """Step 2: the repulsive command (n,), or an empty array when the law gets none."""
    fopt, iopt = coll[3], coll[4]
    if not (coll[0] and iopt[0] != 0 and iopt[1] != 0):
        return np.zeros(0)
    return repulsive(d, J, fopt[0], fopt[1], fopt[2], fopt[3])


@kernel
def shield_step(q: Any, qd: Any, bits: int, prev: Any, d: Any, J: Any, coll: Any) -> Any:
    """Step 3 on the law's command ``qd``: ``(q̇, bits)``."""
    _, arm, geom, fopt, iopt, acc, _, _, _, _, _, cache, scratch = coll
    if not (coll[0] and iopt[2] != 0) or d.shape[0] == 0:
        return qd, bits
    dt, d_safe = fopt[4], fopt[0]
    fill_for_shield(qd, d, J, scratch, geom, dt, fopt[1])
    s, k = shield_scale(qd, d, J, np.zeros(d.shape[0]), dt, d_safe)
    s, k = exact_scale(q, qd, d, J, s, k, dt, d_safe, fopt[1], arm, geom, cache)
    if k < 0:
        return qd, bits
    cmd = qd * s
    bits |= 1 << iopt[3]
    if iopt[5] != 0:
        excess = np.abs(cmd - prev) / dt - acc
        if np.any(excess > 1e-9 * acc):
            bits |= 1 << iopt[4]
    return cmd, bits


@kernel
def keep_measurement(q: Any, d: Any, J: Any, coll: Any) -> None:
    """Keep step 1's measurement ``d``, ``J`` at ``q`` (and its bounds and frames) for the
    same iteration resumed after a Python solve: its step 1 then takes these numbers, as
    it takes the shield check's, instead of measuring again."""
    if not coll[0] or d.shape[0] == 0:
        return
    qc, dc, Jc, valid, lbc, Oc, JOc = coll[11]
    lb, O, JO = coll[12]
    qc[:] = q
    dc[:] = d
    Jc[:, :] = J
    lbc[:], Oc[:, :], JOc[:, :, :] = lb, O, JO
    valid[0] = 1
