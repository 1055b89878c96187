"""Compiled pose interpolation: the camera pose between two control steps.

:class:`redservo.sensors.timing.TimedSensor` needs the camera pose at each instant of an
exposure, between the poses ``T0`` and ``T1`` (4x4) of the control steps around it: the
translation linear, the rotation geodesic, ``R0 exp(u log(R0ᵀ R1))``. The logarithm is
``θ a`` with ``sin θ a = vee(R - Rᵀ)/2``, ``cos θ = (tr R - 1)/2`` and ``θ = atan2(sin, cos)``
(accurate at small angles); near ``π`` the axis comes from ``(R + I)/2 = a aᵀ``. The
exponential is Rodrigues' formula (second order below 1e-8 rad).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["interpolate_pose", "poses_at"]


@kernel
def _log_rotation(R: Any) -> Any:
    """The rotation vector ``θ a`` (rad, θ in [0, π]) of the rotation matrix ``R`` (3x3)."""
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) * 0.5
    s = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    theta = math.atan2(s, c)
    if s > 1e-6:
        return v * (theta / s)
    if c > 0.0:
        return v  # θ = s to third order
    k = 0  # near π: the axis from the largest diagonal entry of (R + I) / 2 = a aᵀ
    for i in range(1, 3):
        if R[i, i] > R[k, k]:
            k = i
    a = np.empty(3)
    for i in range(3):
        a[i] = 0.5 * (R[i, k] + (1.0 if i == k else 0.0))
    a /= math.sqrt(max(a[k], 1e-300))
    a /= math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    if a[0] * v[0] + a[1] * v[1] + a[2] * v[2] < 0.0:
        a = -a
    return a * theta


@kernel
def _exp_rotation(r: Any) -> Any:
    """The rotation matrix (3x3) of the rotation vector ``r`` (rad): Rodrigues' formula."""
    theta = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    K = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    K2 = K @ K
    if theta < 1e-8:
        a, b = 1.0, 0.5
    else:
        a, b = math.sin(theta) / theta, (1.0 - math.cos(theta)) / (theta * theta)
    return np.eye(3) + a * K + b * K2


@kernel
def interpolate_pose(T0: Any, T1: Any, u: float) -> Any:
    """The pose (4x4) a fraction ``u`` in [0, 1] of the way from ``T0`` to ``T1`` (4x4):
    translation ``(1 - u) t0 + u t1``, rotation ``R0 exp(u log(R0ᵀ R1))``."""
    R0 = np.ascontiguousarray(T0[:3, :3])
    R = R0.T @ np.ascontiguousarray(T1[:3, :3])
    T = np.eye(4)
    T[:3, :3] = R0 @ _exp_rotation(u * _log_rotation(R))
    T[:3, 3] = (1.0 - u) * T0[:3, 3] + u * T1[:3, 3]
    return T


@kernel
def poses_at(times: Any, poses: Any, at: Any) -> Any:
    """The poses (k, 4, 4) at the instants ``at`` (k,) (s) of the path through ``poses``
    (m, 4, 4) at the increasing ``times`` (m,) (s): the first pose up to ``times[0]``,
    :func:`interpolate_pose` between the two poses around an instant (the first pair whose
    end is not before it), the last pose after ``times[-1]``."""
    out = np.empty((at.shape[0], 4, 4))
    m = times.shape[0]
    for k in range(at.shape[0]):
        t = at[k]
        if t <= times[0]:
            out[k] = poses[0]
            continue
        out[k] = poses[m - 1]
        for i in range(m - 1):
            if t <= times[i + 1]:
                u = (t - times[i]) / (times[i + 1] - times[i])
                out[k] = interpolate_pose(poses[i], poses[i + 1], u)
                break
    return out
