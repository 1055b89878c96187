"""Broad phase: the pairs the campaign loop and the shield check need, and no others.

The capsule/box and capsule/cylinder distances are searches (:mod:`redservo.kernels.collide`,
about 2 µs); the other pairs are closed forms, whose Jacobians still cost allocations.
:func:`measure_culled` gives every pair's
distance and Jacobian exactly as :func:`~redservo.kernels.loop_collide.pair_distances` does
(the same kernel, :func:`~redservo.kernels.loop_collide.pair_one`, so the same bits) for
the pairs it computes, and ``d = inf``, ``J = 0`` for the pairs it skips. Why the skipped
pairs change nothing that is used:

* **The lower bound.** A box or cylinder lies inside a capsule (the cylinder's own axis and
  radius; a box's longest axis, radius the diagonal of the other two half extents); for
  convex ``A ⊂ B`` the signed distance of a point to ``A`` is at least its signed distance to
  ``B``, so the capsule/capsule distance to the enclosing capsule is at most the true pair
  distance, and the search returns the distance at *some* point of the segment, at least the
  minimum. A sphere, capsule or plane's bound is the pair's own distance (the same closed
  form): skipping saves its Jacobian. :func:`pair_bounds` computes them in scalars, without
  a temporary array (the segment distance of
  :func:`~redservo.kernels.collide.segment_distance`, the plane's heights), which rounds
  differently from the pair's own kernel in the last bits; it subtracts :data:`MARGIN` (1 nm,
  far above the rounding of either computation at workspace scale) and gives ``lb < d`` as
  computed, strictly.
* **The records** (:func:`redservo.kernels.loop_avoid.collide_check`: the smallest distance,
  its pair, the minimum per kind, the steps within ``d_i``, a contact at ``d ≤ 0``): per
  kind, the pairs are taken in ascending ``lb`` and computed until the next one has ``lb >
  d_i`` and ``lb >`` the kind's smallest distance so far; a pair skipped then has ``d > lb``
  above that minimum, so the minimum, its first index and the contact are those of the full
  computation, and every pair closer than ``d_i`` is computed.
* **The repulsion** sums the pairs closer than ``d_i`` in index order: all computed.
* **The shield** (:func:`fill_for_shield`, before
  :func:`~redservo.kernels.loop_collide.shield_scale` and :func:`exact_scale`): a skipped
  pair's rate ``J_d q̇`` is at most ``V = Σ_j max(‖J_A[:, j]‖, ‖J_B[:, j]‖) |q̇_j|`` in size
  (the witness moves with a convex combination of its axis ends, ``J_d`` has a unit
  normal); when ``lb − d_i ≥ dt V (1 + 1e-6) + 1e-12`` its shield bound ``(d − d_s)/(−dt
  J_d q̇)`` is above 1 and its prediction ``d + dt s J_d q̇`` (``s ≤ 1``) stays at or above
  ``d_i``: neither the scale, nor its pair, nor the check's trigger can change. Otherwise
  the pair is computed then.
* **The check** (:func:`exact_scale`) measures with :func:`measure_culled` too: a skipped
  pair has ``d > d_i > d_s ≥ min(d_s, d_k)``, never the pair under its floor.

tests/test_collision_cull.py checks the argument on fuzzed configurations, bit for bit.
Units: m, rad, s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.collide import segment_distance
from redservo.kernels.loop_collide import BOX, PLANE, SPHERE, dh_points, pair_one

__all__ = ["MARGIN", "exact_scale", "fill_for_shield", "measure_culled", "pair_bounds"]

MARGIN = 1e-9
"""m: subtracted from the enclosing-capsule distance (module docstring)."""
_SHRINK, _TRIES = 0.6, 8
""":func:`exact_scale`: the factor and the number of reductions before the scale is 0."""


@kernel
def _hulls(geom: Any) -> Any:
    """``(ends (K, 2, 3), radius (K,))``: each obstacle as a capsule, the obstacle itself
    (a sphere: a point) or the capsule enclosing a cylinder or a box (module docstring);
    planes are measured as planes."""
    ob_kind, ob_M, ob_size = geom[2], geom[3], geom[4]
    K = ob_kind.shape[0]
    ends, radius = np.zeros((K, 2, 3)), np.zeros(K)
    for o in range(K):
        M, size, axis, radius[o] = ob_M[o], ob_size[o], 2, ob_size[o][0]
        half = 0.0 if ob_kind[o] == SPHERE else 0.5 * size[1]
        if ob_kind[o] == BOX:
            axis = int(np.argmax(size))
            i, j = (axis + 1) % 3, (axis + 2) % 3
            half, radius[o] = size[axis], np.sqrt(size[i] * size[i] + size[j] * size[j])
        for k in range(3):
            ends[o, 0, k] = M[k, 3] - half * M[k, axis]
            ends[o, 1, k] = M[k, 3] + half * M[k, axis]
    return ends, radius


@kernel
def _plane_gap(A: Any, B: Any, M: Any) -> float:
    """The lower height (m) of the points ``A``, ``B`` above the plane of pose ``M``."""
    h0 = h1 = 0.0
    for k in range(3):
        h0 += (A[k] - M[k, 3]) * M[k, 2]
        h1 += (B[k] - M[k, 3]) * M[k, 2]
    return min(h0, h1)


@kernel
def pair_bounds(O: Any, geom: Any) -> Any:
    """``lb (P,)``: a lower bound of each pair's distance (m) at the frame origins ``O``;
    ``-inf`` for the self pairs (always computed). Scalar closed forms, no temporaries
    per pair (their rounding differs from the pair's own by far less than :data:`MARGIN`)."""
    cap_ab, cap_r, ob_kind, ob_M, self_ab = geom[0], geom[1], geom[2], geom[3], geom[5]
    C, K = cap_ab.shape[0], ob_kind.shape[0]
    lb = np.full(C * K + self_ab.shape[0], -np.inf)
    ends, radius = _hulls(geom)
    for p in range(C * K):
        o, c = p // C, p % C
        A, B = O[cap_ab[c, 0]], O[cap_ab[c, 1]]
        if ob_kind[o] == PLANE:
            gap = _plane_gap(A, B, ob_M[o])
        else:
            gap = segment_distance(A, B, ends[o, 0], ends[o, 1]) - radius[o]
        lb[p] = gap - cap_r[c] - MARGIN
    return lb


@kernel
def measure_culled(q: Any, arm: Any, geom: Any, d_influence: float) -> Any:
    """``(d (P,), J (P, n), lb (P,), O, JO)`` at ``q``: the pairs the records and the laws
    need (module docstring), ``inf`` and zeros for the others; ``O, JO`` from
    :func:`~redservo.kernels.loop_collide.dh_points`."""
    O, JO = dh_points(q, arm)
    lb = pair_bounds(O, geom)
    P, CK = lb.shape[0], geom[0].shape[0] * geom[2].shape[0]
    d, J = np.full(P, np.inf), np.zeros((P, q.shape[0]))
    for lo, hi in ((0, CK), (CK, P)):
        order = np.argsort(lb[lo:hi], kind="mergesort")
        least = np.inf
        for i in order:
            p = lo + i
            if lb[p] > d_influence and lb[p] > least:
                break
            dk, Jk, _, _ = pair_one(p, O, JO, geom)
            d[p], J[p] = dk, Jk
            least = min(least, dk)
    return d, J, lb, O, JO


@kernel
def _speed_bound(qd: Any, JA: Any, JB: Any) -> float:
    """``Σ_j max(‖J_A[:, j]‖, ‖J_B[:, j]‖) |q̇_j|`` (m/s): no point of the axis is faster."""
    v = 0.0
    for j in range(qd.shape[0]):
        a = np.sqrt(JA[0, j] ** 2 + JA[1, j] ** 2 + JA[2, j] ** 2)
        b = np.sqrt(JB[0, j] ** 2 + JB[1, j] ** 2 + JB[2, j] ** 2)
        v += max(a, b) * abs(qd[j])
    return v


@kernel
def fill_for_shield(qd: Any, d: Any, J: Any, scratch: Any, geom: Any, dt: float, d_i: float) -> int:
    """Compute, into ``d`` and ``J``, the skipped pairs the shield of ``qd`` could see
    (module docstring); ``scratch = (lb, O, JO)`` of :func:`measure_culled`. Returns how
    many were computed."""
    lb, O, JO = scratch
    cap_ab = geom[0]
    C, CK = cap_ab.shape[0], cap_ab.shape[0] * geom[2].shape[0]
    filled = 0
    speed = np.full(C, -1.0)  # each capsule's bound, computed once (when a pair needs it)
    for p in range(CK):
        if d[p] != np.inf:
            continue
        c = p % C
        if speed[c] < 0.0:
            speed[c] = _speed_bound(qd, JO[cap_ab[c, 0]], JO[cap_ab[c, 1]])
        if lb[p] - d_i >= dt * speed[c] * (1.0 + 1e-6) + 1e-12:
            continue
        dk, Jk, _, _ = pair_one(p, O, JO, geom)
        d[p], J[p] = dk, Jk
        filled += 1
    return filled


@kernel
def exact_scale(
    q: Any,
    qd: Any,
    d: Any,
    J: Any,
    s: float,
    k: int,
    dt: float,
    d_safe: float,
    d_influence: float,
    arm: Any,
    geom: Any,
    cache: Any,
) -> Any:
    """The shield's ``(s, k)`` checked on the true geometry at ``q + dt s q̇`` (static
    obstacles): while a pair would land under ``min(d_s, d_k)``, ``s`` shrinks by 0.6 (at
    most 8 times, then 0). ``cache = (q, d, J, valid, lb, O, JO)``: where the last
    measurement (:func:`measure_culled`) was taken and what it gave (the campaign loop's
    next step starts there when the shield left the command alone); zero-size arrays keep
    nothing."""
    if s <= 0.0:
        return s, k
    ahead = d + dt * s * np.dot(J, qd)
    if not np.any(ahead < d_influence):
        return s, k
    floor = np.minimum(d_safe, d)
    qc, dc, Jc, valid, lbc, Oc, JOc = cache
    for _ in range(_TRIES):
        qa = q + dt * s * qd
        dm, Jm, lb, O, JO = measure_culled(qa, arm, geom, d_influence)
        if qc.shape[0] == qa.shape[0]:
            qc[:], dc[:], Jc[:, :], valid[0] = qa, dm, Jm, 1
            lbc[:], Oc[:, :], JOc[:, :, :] = lb, O, JO
        gap = dm - floor
        j = int(np.argmin(gap))
        if gap[j] >= 0.0:
            return s, k
        s, k = _SHRINK * s, j
    return 0.0, k
