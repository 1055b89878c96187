"""Kinematics kernels of a generic serial chain: fixed transforms and joint axes.

A chain of n joints is two arrays (:class:`redservo.robots.chain.ChainRobot` builds them,
e.g. from a URDF file):

* ``frames`` (n+1, 3, 4): the rigid transforms ``[R | t]`` (t in m) that do not move:
  ``frames[i]`` is the pose of joint i's frame in the frame before it (the base for
  i = 0, else the frame joint i-1 moved), and ``frames[n]`` the pose of the end-effector
  frame ``e`` in the frame the last joint moved;
* ``joints`` (n, 4): per joint, its unit axis ``(x, y, z)`` in its own frame, then
  :data:`PRISMATIC` flag 1.0 (prismatic: a translation of ``q_i`` m along the axis) or
  0.0 (revolute: a rotation of ``q_i`` rad about the axis through the frame's origin).

Then ``bMe = F_0 M_0(q_0) F_1 M_1(q_1) ⋯ F_{n-1} M_{n-1}(q_{n-1}) F_n`` and ``eJe`` is the
geometric Jacobian of frame ``e`` expressed in ``e`` (the URDF / Pinocchio ``LOCAL``
convention, ``(v, ω)`` with ``v`` the velocity of the origin of ``e``): with ``z_j`` the
axis and ``p_j`` the origin of joint j's frame in the base frame and ``p_e`` the origin of
``e``, column j is ``(z_j × (p_e - p_j), z_j)`` (revolute) or ``(z_j, 0)`` (prismatic),
rotated into ``e``. The camera quantities follow the Robot protocol
(:mod:`redservo.robots.base`): ``bMc = bMe eMc`` and ``J = cVe eJe``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.kinematics import matmul

__all__ = ["PRISMATIC", "chain_forward", "chain_jacobe", "chain_kinematics", "chain_robot"]

PRISMATIC = 3
"""Column of ``joints`` holding the prismatic flag (1.0 prismatic, 0.0 revolute)."""


@kernel
def _compose(R: Any, t: Any, F: Any) -> None:
    """``(R, t) <- (R, t) · F`` in place, ``F`` a (3, 4) rigid transform ``[R_F | t_F]``."""
    for r in range(3):
        a0 = R[r, 0]
        a1 = R[r, 1]
        a2 = R[r, 2]
        t[r] += a0 * F[0, 3] + a1 * F[1, 3] + a2 * F[2, 3]
        for c in range(3):
            R[r, c] = a0 * F[0, c] + a1 * F[1, c] + a2 * F[2, c]


@kernel
def _rotate(R: Any, kx: float, ky: float, kz: float, angle: float) -> None:
    """``R <- R · Rot(k, angle)`` in place (Rodrigues' formula, ``k`` a unit axis)."""
    c = math.cos(angle)
    s = math.sin(angle)
    v = 1.0 - c
    m00 = c + kx * kx * v
    m01 = kx * ky * v - kz * s
    m02 = kx * kz * v + ky * s
    m10 = ky * kx * v + kz * s
    m11 = c + ky * ky * v
    m12 = ky * kz * v - kx * s
    m20 = kz * kx * v - ky * s
    m21 = kz * ky * v + kx * s
    m22 = c + kz * kz * v
    for r in range(3):
        a0 = R[r, 0]
        a1 = R[r, 1]
        a2 = R[r, 2]
        R[r, 0] = a0 * m00 + a1 * m10 + a2 * m20
        R[r, 1] = a0 * m01 + a1 * m11 + a2 * m21
        R[r, 2] = a0 * m02 + a1 * m12 + a2 * m22


@kernel
def chain_forward(q: Any, frames: Any, joints: Any) -> Any:
    """``(bMe, Z, P)``: the end-effector pose (4x4, m) and, per joint, its axis ``z_j``
    (n, 3) and the origin ``p_j`` of its frame (n, 3, m), in the base frame."""
    n = q.shape[0]
    R = np.eye(3)
    t = np.zeros(3)
    Z = np.empty((n, 3))
    P = np.empty((n, 3))
    for i in range(n):
        _compose(R, t, frames[i])
        kx = joints[i, 0]
        ky = joints[i, 1]
        kz = joints[i, 2]
        for r in range(3):
            Z[i, r] = R[r, 0] * kx + R[r, 1] * ky + R[r, 2] * kz
            P[i, r] = t[r]
        if joints[i, PRISMATIC] != 0.0:
            for r in range(3):
                t[r] += q[i] * Z[i, r]
        else:
            _rotate(R, kx, ky, kz, q[i])
    _compose(R, t, frames[n])
    bMe = np.zeros((4, 4))
    for r in range(3):
        for c in range(3):
            bMe[r, c] = R[r, c]
        bMe[r, 3] = t[r]
    bMe[3, 3] = 1.0
    return bMe, Z, P


@kernel
def chain_jacobe(bMe: Any, Z: Any, P: Any, joints: Any) -> Any:
    """``eJe`` (6, n) from :func:`chain_forward`'s outputs: columns ``(z_j × (p_e - p_j),
    z_j)`` (revolute) or ``(z_j, 0)`` (prismatic), rotated into the end-effector frame."""
    n = Z.shape[0]
    J = np.empty((6, n))
    ze = np.empty(3)
    de = np.empty(3)
    for j in range(n):
        for c in range(3):
            zc = 0.0
            dc = 0.0
            for r in range(3):
                zc += Z[j, r] * bMe[r, c]
                dc += (bMe[r, 3] - P[j, r]) * bMe[r, c]
            ze[c] = zc
            de[c] = dc
        if joints[j, PRISMATIC] != 0.0:
            for c in range(3):
                J[c, j] = ze[c]
                J[3 + c, j] = 0.0
        else:
            J[0, j] = ze[1] * de[2] - ze[2] * de[1]
            J[1, j] = ze[2] * de[0] - ze[0] * de[2]
            J[2, j] = ze[0] * de[1] - ze[1] * de[0]
            for c in range(3):
                J[3 + c, j] = ze[c]
    return J


@kernel
def chain_kinematics(q: Any, frames: Any, joints: Any, eMc: Any, cVe: Any) -> Any:
    """``(bMc, J)`` of a chain: the camera pose ``bMe eMc`` (4x4, m) and ``J = cVe eJe``
    (6, n), with ``v_c = J q̇`` the camera twist in the camera frame."""
    bMe, Z, P = chain_forward(q, frames, joints)
    return matmul(bMe, eMc), matmul(cVe, chain_jacobe(bMe, Z, P, joints))


@kernel
def chain_robot(q: Any, eMc: Any, cVe: Any, scalars: Any, table: Any, frames: Any) -> Any:
    """The chain kind of the robot pack (:mod:`redservo.kernels.robot_kinds`): ``table`` the
    (n, 4) joint axes, ``frames`` the (n + 1, 3, 4) fixed transforms; ``(bMc, J)`` as
    :func:`chain_kinematics`."""
    return chain_kinematics(q, frames, table, eMc, cVe)
