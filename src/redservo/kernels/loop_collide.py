"""Collision pairs in compiled code: one implementation for the Controller and the campaign loop.

A robot whose collision model is one capsule per link of a DH chain
(:mod:`redservo.collision.robot`) among static primitive obstacles is measured here:
:func:`dh_points` gives the link-frame origins and their Jacobians, :func:`pair_distances`
every pair's signed distance and Jacobian ``J_d = nᵀ (J_p(a) − J_p(b))`` with the primitive
kernels of :mod:`redservo.kernels.collide`. :class:`~redservo.control.avoidance.Collision`
measures with these kernels when it can (:mod:`redservo.collision.pack`), and so does the
compiled campaign loop (:mod:`redservo.kernels.loop_avoid`, which skips the pairs that
cannot matter: :mod:`redservo.kernels.loop_cull`): both paths get the same numbers to the
bit. :func:`repulsive`, :func:`shield_scale` and
:func:`redservo.kernels.loop_cull.exact_scale` are the arithmetic of
:mod:`redservo.control.avoidance` (its docstrings give the equations).

Packs: ``arm = (par, base, flange, standard)`` (:mod:`redservo.kernels.kinematics`);
``geom = (cap_ab (C, 2) frame indices, cap_r (C,) radii, ob_kind (K,), ob_M (K, 4, 4),
ob_size (K, 3), self_ab (S, 2) capsule indices)``; obstacle kinds :data:`SPHERE`,
:data:`CAPSULE`, :data:`CYLINDER`, :data:`BOX`, :data:`PLANE`; ``ob_size`` is ``(radius,
length, 0)`` or a box's half extents. Pairs: every capsule against each obstacle in turn,
then the self pairs. Units: m, rad, s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.collide import (
    capsule_box,
    capsule_capsule,
    capsule_cylinder,
    capsule_plane,
)
from redservo.kernels.kinematics import dh_links, matmul

__all__ = [
    "BOX",
    "CAPSULE",
    "CYLINDER",
    "PLANE",
    "SPHERE",
    "dh_points",
    "measure_arm",
    "pair_distances",
    "pair_one",
    "repulsive",
    "shield_scale",
]

SPHERE, CAPSULE, CYLINDER, BOX, PLANE = 0, 1, 2, 3, 4
"""Obstacle kinds of the ``geom`` pack."""


@kernel
def dh_points(q: Any, arm: Any) -> Any:
    """``(O, JO)``: the origins (F, 3) of the frames ``base, joint 1 … n, ee`` of a DH chain
    (m, base frame) and their Jacobians (F, 3, n), column ``j`` of frame ``k`` being
    ``z_j × (o_k − p_j)`` (revolute) or ``z_j`` (prismatic) for ``j < k``, else 0."""
    par, base, flange, standard = arm
    n = q.shape[0]
    links = dh_links(q, par, standard)
    O = np.zeros((n + 2, 3))
    Z = np.empty((n, 3))
    P = np.empty((n, 3))
    M = base.copy()
    O[0] = M[:3, 3]
    for i in range(n):
        if standard:
            Z[i], P[i] = M[:3, 2], M[:3, 3]
        M = matmul(M, links[i])
        if not standard:
            Z[i], P[i] = M[:3, 2], M[:3, 3]
        O[i + 1] = M[:3, 3]
    O[n + 1] = matmul(M, flange)[:3, 3]
    JO = np.zeros((n + 2, 3, n))
    for k in range(n + 2):
        for j in range(min(k, n)):
            if par[7, j] != 0.0:  # prismatic
                JO[k, :, j] = Z[j]
            else:
                r = O[k] - P[j]
                JO[k, 0, j] = Z[j, 1] * r[2] - Z[j, 2] * r[1]
                JO[k, 1, j] = Z[j, 2] * r[0] - Z[j, 0] * r[2]
                JO[k, 2, j] = Z[j, 0] * r[1] - Z[j, 1] * r[0]
    return O, JO


@kernel
def _axis_jacobian(p: Any, A: Any, B: Any, JA: Any, JB: Any) -> Any:
    """(3, n) velocity of the point of the axis ``A B`` nearest to ``p``: ``(1 − s) J_A +
    s J_B``, element by element in one array (numpy's operations, without temporaries)."""
    ab = B - A
    s = min(max(np.dot(p - A, ab) / np.dot(ab, ab), 0.0), 1.0)
    out = np.empty(JA.shape)
    for i in range(3):
        for j in range(JA.shape[1]):
            out[i, j] = (1.0 - s) * JA[i, j] + s * JB[i, j]
    return out


@kernel
def _obstacle(A: Any, B: Any, r: float, kind: int, M: Any, size: Any) -> Any:
    """``(d, wa, wb)`` of the capsule ``(A, B, r)`` against one obstacle."""
    if kind == BOX:
        return capsule_box(A, B, r, M, size)
    if kind == CYLINDER:
        return capsule_cylinder(A, B, r, M, size)
    if kind == PLANE:
        return capsule_plane(A, B, r, np.ascontiguousarray(M[:3, 3]), M[:3, 2].copy())
    c = np.ascontiguousarray(M[:3, 3])
    if kind == SPHERE:
        return capsule_capsule(A, B, r, c, c, size[0])
    half = 0.5 * size[1] * M[:3, 2]
    return capsule_capsule(A, B, r, c - half, c + half, size[0])


@kernel
def _normal(d: float, a: Any, b: Any, A: Any, B: Any) -> Any:
    """Unit vector from ``b`` towards ``a`` (away from ``b`` when they overlap; from ``b``
    towards the middle of the axis ``A B`` when they coincide)."""
    v = a - b
    norm = np.sqrt(np.dot(v, v))
    if norm < 1e-12:
        fallback = 0.5 * (A + B) - b
        return fallback / np.sqrt(np.dot(fallback, fallback))
    return v / norm if d >= 0.0 else -v / norm


@kernel
def pair_one(p: int, O: Any, JO: Any, geom: Any) -> Any:
    """``(d, J_d (n,), wb (3,), normal (3,))`` of pair ``p`` (module docstring)."""
    cap_ab, cap_r, ob_kind, ob_M, ob_size, self_ab = geom
    C, K = cap_ab.shape[0], ob_kind.shape[0]
    c = p % C if p < C * K else self_ab[p - C * K, 0]
    A, B = O[cap_ab[c, 0]], O[cap_ab[c, 1]]
    JA, JB = JO[cap_ab[c, 0]], JO[cap_ab[c, 1]]
    if p < C * K:  # a static obstacle: J_b = 0, and x - 0 is x
        o = p // C
        dk, a, b = _obstacle(A, B, cap_r[c], ob_kind[o], ob_M[o], ob_size[o])
        nv = _normal(dk, a, b, A, B)
        return dk, np.dot(nv, _axis_jacobian(a, A, B, JA, JB)), b, nv
    e = self_ab[p - C * K, 1]
    A2, B2 = O[cap_ab[e, 0]], O[cap_ab[e, 1]]
    dk, a, b = capsule_capsule(A, B, cap_r[c], A2, B2, cap_r[e])
    Jb = _axis_jacobian(b, A2, B2, JO[cap_ab[e, 0]], JO[cap_ab[e, 1]])
    nv = _normal(dk, a, b, A, B)
    return dk, np.dot(nv, _axis_jacobian(a, A, B, JA, JB) - Jb), b, nv


@kernel
def pair_distances(O: Any, JO: Any, geom: Any) -> Any:
    """``(d (P,), J (P, n), wb (P, 3), normal (P, 3))`` of every pair (module docstring)."""
    cap_ab, ob_kind, self_ab = geom[0], geom[2], geom[5]
    P = cap_ab.shape[0] * ob_kind.shape[0] + self_ab.shape[0]
    n = JO.shape[2]
    d, J = np.empty(P), np.zeros((P, n))
    wb, nrm = np.zeros((P, 3)), np.zeros((P, 3))
    for p in range(P):
        dk, Jk, bk, nk = pair_one(p, O, JO, geom)
        d[p], J[p], wb[p], nrm[p] = dk, Jk, bk, nk
    return d, J, wb, nrm


@kernel
def measure_arm(q: Any, arm: Any, geom: Any) -> Any:
    """:func:`pair_distances` at ``q`` (n,) of the DH chain ``arm``: ``(d, J, wb, normal)``."""
    O, JO = dh_points(q, arm)
    return pair_distances(O, JO, geom)


@kernel
def repulsive(d: Any, J: Any, d_safe: float, d_influence: float, xi: float, mu: float) -> Any:
    """``q̇_rep = Σ_k J_kᵀ v_k / (‖J_k‖² + μ²)`` over the pairs closer than ``d_i``, with
    ``v_k = ξ (d_i − d_k)/(d_i − d_s)`` (m/s): the repulsive command (n,), rad/s or m/s."""
    n = J.shape[1]
    out = np.zeros(n)
    for k in range(d.shape[0]):
        if d[k] < d_influence:
            v = xi * (d_influence - d[k]) / (d_influence - d_safe)
            w = v / (np.dot(J[k], J[k]) + mu * mu)
            for j in range(n):
                out[j] += w * J[k, j]
    return out


@kernel
def shield_scale(qd: Any, d: Any, J: Any, drift: Any, dt: float, d_safe: float) -> Any:
    """``(s, k)``: the largest scale of ``qd`` keeping every pair's first-order prediction at
    ``d_s`` one period ahead (or never closer inside it); ``k`` the bounding pair, -1 at 1."""
    rate = np.dot(J, qd)
    best, k = np.inf, -1
    for p in range(d.shape[0]):
        if rate[p] < 0.0:
            rest = d[p] + dt * drift[p]
            room = rest - d_safe if rest >= d_safe else 0.0
            approach = -dt * rate[p]  # m in one period: 0 when the product underflows
            if approach > 0.0:
                bound = room / approach
            else:  # no representable approach: no bound, except for a pair at or inside d_s
                bound = np.inf if room > 0.0 else 0.0
            if bound < best:
                best, k = bound, p
    if k < 0 or best >= 1.0:
        return 1.0, -1
    # One ulp below the bound, so that rounding does not land the prediction under d_s.
    return (max(np.nextafter(best, -np.inf), 0.0) if best > 0.0 else 0.0), k
