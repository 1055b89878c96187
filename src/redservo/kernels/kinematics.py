"""Kinematics kernels: the Afma6 gantry and serial chains from Denavit–Hartenberg tables.

The models are documented in :mod:`redservo.robots.afma6` and :mod:`redservo.robots.dh`,
which wrap these kernels. Every kernel returns the camera pose ``bMc`` (4x4) and the
Jacobian ``J = cVe eJe`` (6, n) with ``v_c = J q̇`` (or the end-effector quantities).

DH parameters are packed in a (8, n) array, rows :data:`DH_ROWS`: the joint offset, the
constant θ and d, the link length a, cos α, sin α, and 1.0/0.0 flags for revolute and
prismatic joints.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = [
    "DH_ROWS",
    "afma6_fkine_ee",
    "afma6_jacobe",
    "afma6_kinematics",
    "afma6_robot",
    "dh_chain",
    "dh_jacobe",
    "dh_kinematics",
    "dh_robot",
    "matmul",
]

DH_ROWS = ("offset", "theta", "d", "a", "cos_alpha", "sin_alpha", "revolute", "prismatic")
OFF, TH0, D0, A, CA, SA, REV, PRI = range(8)


@kernel
def matmul(A: Any, B: Any) -> Any:
    """``A @ B`` for small matrices (loops; no BLAS call)."""
    m, k = A.shape
    n = B.shape[1]
    C = np.empty((m, n))
    for i in range(m):
        for j in range(n):
            acc = 0.0
            for l in range(k):
                acc += A[i, l] * B[l, j]
            C[i, j] = acc
    return C


@kernel
def _afma6_rotation(q: Any, coupling: float) -> Any:
    c1 = math.cos(q[3])
    s1 = math.sin(q[3])
    c2 = math.cos(q[4])
    s2 = math.sin(q[4])
    c3q = q[5] - coupling * q[4]
    c3 = math.cos(c3q)
    s3 = math.sin(c3q)
    R = np.empty((3, 3))
    R[0, 0] = s1 * s2 * c3 + c1 * s3
    R[0, 1] = -s1 * s2 * s3 + c1 * c3
    R[0, 2] = -s1 * c2
    R[1, 0] = -c1 * s2 * c3 + s1 * s3
    R[1, 1] = c1 * s2 * s3 + s1 * c3
    R[1, 2] = c1 * c2
    R[2, 0] = c2 * c3
    R[2, 1] = -c2 * s3
    R[2, 2] = s2
    return R, c1, s1, c2, s2


@kernel
def afma6_fkine_ee(q: Any, coupling: float, offset: float) -> Any:
    """``fMe`` (4x4) of the Afma6 (robots/afma6.py)."""
    R, c1, s1, _, _ = _afma6_rotation(q, coupling)
    T = np.zeros((4, 4))
    T[:3, :3] = R
    T[0, 3] = q[0] + offset * c1
    T[1, 3] = q[1] + offset * s1
    T[2, 3] = q[2]
    T[3, 3] = 1.0
    return T


@kernel
def _rt_times(R: Any, x: float, y: float, z: float, out: Any, row: int, col: int) -> None:
    """``out[row:row+3, col] = R^T (x, y, z)``."""
    for i in range(3):
        out[row + i, col] = R[0, i] * x + R[1, i] * y + R[2, i] * z


@kernel
def afma6_jacobe(q: Any, coupling: float, offset: float) -> Any:
    """``eJe`` (6, 6) of the Afma6: ``blkdiag(fRe^T, fRe^T) fJe`` (robots/afma6.py)."""
    R, c1, s1, c2, s2 = _afma6_rotation(q, coupling)
    J = np.zeros((6, 6))
    for i in range(3):
        for j in range(3):
            J[i, j] = R[j, i]
    _rt_times(R, -offset * s1, offset * c1, 0.0, J, 0, 3)
    for i in range(3):
        J[3 + i, 3] = R[2, i]
    _rt_times(R, c1 + coupling * s1 * c2, s1 - coupling * c1 * c2, -coupling * s2, J, 3, 4)
    _rt_times(R, -s1 * c2, c1 * c2, s2, J, 3, 5)
    return J


@kernel
def afma6_kinematics(q: Any, eMc: Any, cVe: Any, coupling: float, offset: float) -> Any:
    """``(bMc, J)``: camera pose ``fMe eMc`` and ``J = cVe eJe`` of the Afma6."""
    return (
        matmul(afma6_fkine_ee(q, coupling, offset), eMc),
        matmul(cVe, afma6_jacobe(q, coupling, offset)),
    )


@kernel
def _link(ct: float, st: float, ca: float, sa: float, a: float, d: float, std: bool) -> Any:
    A_ = np.zeros((4, 4))
    A_[3, 3] = 1.0
    if std:  # Rz(θ) Tz(d) Tx(a) Rx(α)
        A_[0, 0] = ct
        A_[0, 1] = -st * ca
        A_[0, 2] = st * sa
        A_[0, 3] = a * ct
        A_[1, 0] = st
        A_[1, 1] = ct * ca
        A_[1, 2] = -ct * sa
        A_[1, 3] = a * st
        A_[2, 1] = sa
        A_[2, 2] = ca
        A_[2, 3] = d
    else:  # Rx(α) Tx(a) Rz(θ) Tz(d)
        A_[0, 0] = ct
        A_[0, 1] = -st
        A_[0, 3] = a
        A_[1, 0] = st * ca
        A_[1, 1] = ct * ca
        A_[1, 2] = -sa
        A_[1, 3] = -sa * d
        A_[2, 0] = st * sa
        A_[2, 1] = ct * sa
        A_[2, 2] = ca
        A_[2, 3] = ca * d
    return A_


@kernel
def dh_links(q: Any, par: Any, standard: bool) -> Any:
    """(n, 4, 4) link transforms ``A_i(q_i)`` (robots/dh.py)."""
    n = q.shape[0]
    out = np.empty((n, 4, 4))
    for i in range(n):
        jv = q[i] + par[OFF, i]
        theta = par[TH0, i] + par[REV, i] * jv
        d = par[D0, i] + par[PRI, i] * jv
        out[i] = _link(
            math.cos(theta), math.sin(theta), par[CA, i], par[SA, i], par[A, i], d, standard
        )
    return out


@kernel
def dh_chain(q: Any, par: Any, base: Any, flange: Any, standard: bool) -> Any:
    """``(bMe, Z, P)``: end-effector pose and the joint axes (n, 3) and points on them (n, 3)
    in the base frame (standard DH: joint i acts on frame i-1; modified: on frame i)."""
    n = q.shape[0]
    links = dh_links(q, par, standard)
    Z = np.empty((n, 3))
    P = np.empty((n, 3))
    M = base.copy()
    for i in range(n):
        if standard:
            for r in range(3):
                Z[i, r] = M[r, 2]
                P[i, r] = M[r, 3]
        M = matmul(M, links[i])
        if not standard:
            for r in range(3):
                Z[i, r] = M[r, 2]
                P[i, r] = M[r, 3]
    return matmul(M, flange), Z, P


@kernel
def dh_jacobe(bMe: Any, Z: Any, P: Any, par: Any) -> Any:
    """Analytic ``eJe`` (6, n): columns ``(z_j × (p_e - p_j), z_j)`` (revolute) or ``(z_j, 0)``
    (prismatic), rotated into the end-effector frame."""
    n = Z.shape[0]
    J = np.empty((6, n))
    for j in range(n):
        ze = np.zeros(3)
        de = np.zeros(3)
        for c in range(3):
            for r in range(3):
                ze[c] += Z[j, r] * bMe[r, c]
                de[c] += (bMe[r, 3] - P[j, r]) * bMe[r, c]
        rev = par[REV, j]
        pri = par[PRI, j]
        J[0, j] = rev * (ze[1] * de[2] - ze[2] * de[1]) + pri * ze[0]
        J[1, j] = rev * (ze[2] * de[0] - ze[0] * de[2]) + pri * ze[1]
        J[2, j] = rev * (ze[0] * de[1] - ze[1] * de[0]) + pri * ze[2]
        J[3, j] = ze[0] * rev
        J[4, j] = ze[1] * rev
        J[5, j] = ze[2] * rev
    return J


@kernel
def dh_kinematics(
    q: Any, par: Any, base: Any, flange: Any, standard: bool, eMc: Any, cVe: Any
) -> Any:
    """``(bMc, J)`` of a DH chain: camera pose ``bMe eMc`` and ``J = cVe eJe``."""
    bMe, Z, P = dh_chain(q, par, base, flange, standard)
    return matmul(bMe, eMc), matmul(cVe, dh_jacobe(bMe, Z, P, par))


@kernel
def afma6_robot(q: Any, eMc: Any, cVe: Any, scalars: Any, table: Any, frames: Any) -> Any:
    """The Afma6 kind of the robot pack (:mod:`redservo.kernels.robot_kinds`): ``scalars``
    is ``(coupling, offset)`` (1, m); ``(bMc, J)`` as :func:`afma6_kinematics`."""
    return afma6_kinematics(q, eMc, cVe, scalars[0], scalars[1])


@kernel
def dh_robot(q: Any, eMc: Any, cVe: Any, scalars: Any, table: Any, frames: Any) -> Any:
    """The DH kind of the robot pack: ``scalars`` is ``(standard,)`` (1.0 or 0.0), ``table``
    the (8, n) DH table, ``frames`` (2, 4, 4) the base and flange transforms (m);
    ``(bMc, J)`` as :func:`dh_kinematics`."""
    return dh_kinematics(q, table, frames[0], frames[1], scalars[0] != 0.0, eMc, cVe)
