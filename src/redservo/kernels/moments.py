"""Kernels of the decoupled moment features of coplanar points (Tahri & Chaumette 2005).

Definitions, interaction matrices and decisions: :mod:`redservo.features.moments`, which
wraps these kernels. This module measures (moments, plane, invariants, features); their
interaction matrices are in :mod:`redservo.kernels.moment_interaction`. Moments are held as a (5, 5) array ``mu[i, j] = μ_ij`` (``i + j <= 4``)
with the centroid ``(xg, yg)``; ``kind`` selects the rotation features: 0 ``"c4c6"``,
1 ``"pxpy"``, 2 ``"sxsy"``. Derivatives of the rotation features use complex steps, so
:func:`rotation_invariants` is compiled for real and for complex input from one source.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.lapack import gesvd_sv

__all__ = [
    "check_moments",
    "fit_plane",
    "image_moments",
    "moment_features",
    "moment_measure",
    "rotation_invariants",
]

ORDER = 4
PLANE_TOL = 1e-8
ISOTROPY_TOL = 1e-9
SYMMETRY_TOL = 1e-6
I6_TOL = 1e-9
MIN_DEPTH = 1e-6
(
    OK,
    BEHIND,
    COLLINEAR,
    NOT_COPLANAR,
    THROUGH_CENTRE,
    COINCIDE,
    ISOTROPIC,
    SYMMETRIC,
    I6_ZERO,
    PLANE_BEHIND,
) = range(10)
"""Error codes (the messages are in features/moments.py)."""
INV_KEYS = ((2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3))


@kernel
def image_moments(xy: Any) -> Any:
    """``(xg, yg, mu)``: centroid and centred moments up to order 4 of N points (N, 2)."""
    n = xy.shape[0]
    sx = 0.0
    sy = 0.0
    for k in range(n):
        sx += xy[k, 0]
        sy += xy[k, 1]
    xg = sx / n
    yg = sy / n
    mu = np.zeros((ORDER + 1, ORDER + 1))
    px = np.empty(ORDER + 1)
    py = np.empty(ORDER + 1)
    for k in range(n):
        dx = xy[k, 0] - xg
        dy = xy[k, 1] - yg
        px[0] = 1.0
        py[0] = 1.0
        for i in range(1, ORDER + 1):
            px[i] = px[i - 1] * dx
            py[i] = py[i - 1] * dy
        for i in range(ORDER + 1):
            for j in range(ORDER + 1 - i):
                mu[i, j] += px[i] * py[j]
    return xg, yg, mu


@kernel
def fit_plane(P: Any) -> Any:
    """``(plane, code, value)``: ``(A, B, C)`` with ``1/Z = A x + B y + C`` on the plane of the
    camera-frame points (N, 3); codes COLLINEAR, NOT_COPLANAR (value: out-of-plane spread
    relative to in-plane), THROUGH_CENTRE (value: distance of the plane, m)."""
    n = P.shape[0]
    c = np.zeros(3)
    for k in range(n):
        for r in range(3):
            c[r] += P[k, r]
    for r in range(3):
        c[r] = c[r] / n
    Q = np.empty((n, 3))
    for k in range(n):
        for r in range(3):
            Q[k, r] = P[k, r] - c[r]
    sv, V, _ = gesvd_sv(Q)  # dgesvd without U: the same σ and V (kernels/lapack.py)
    plane = np.zeros(3)
    if sv[0] <= 0.0 or sv[1] <= PLANE_TOL * sv[0]:
        return plane, COLLINEAR, 0.0
    if sv[2] > PLANE_TOL * sv[0]:
        return plane, NOT_COPLANAR, sv[2] / sv[0]
    d = V[0, 2] * c[0] + V[1, 2] * c[1] + V[2, 2] * c[2]
    if abs(d) <= 1e-6:
        return plane, THROUGH_CENTRE, abs(d)
    for r in range(3):
        plane[r] = V[r, 2] / d
    return plane, OK, 0.0


@kernel
def _p2(z: Any) -> Any:
    """``z²`` by multiplication (numba's complex ``**`` goes through exp/log, which is not
    exact for the complex steps on a negative real part)."""
    return z * z


@kernel
def _p3(z: Any) -> Any:
    return z * z * z


@kernel
def _p4(z: Any) -> Any:
    z2 = z * z
    return z2 * z2


@kernel
def _i6(m30: Any, m21: Any, m12: Any, m03: Any) -> Any:
    return (
        3 * _p4(m12)
        + 2 * m30 * _p3(m12)
        + (3 * _p2(m30) - 6 * m03 * m21) * _p2(m12)
        - 6 * m30 * m21 * (m21 + m03) * m12
        + 2 * _p2(m30) * _p2(m03)
        + 2 * _p3(m21) * m03
        + 3 * _p2(m21) * _p2(m03)
        + 3 * _p4(m21)
    )


@kernel
def rotation_invariants(mu7: Any, kind: int) -> Any:
    """The two rotation features (2,) from ``(μ20, μ11, μ02, μ30, μ21, μ12, μ03)`` (real or
    complex, same dtype out)."""
    m20 = mu7[0]
    m11 = mu7[1]
    m02 = mu7[2]
    m30 = mu7[3]
    m21 = mu7[4]
    m12 = mu7[5]
    m03 = mu7[6]
    out = np.empty(2, dtype=mu7.dtype)
    if kind == 0:
        I6 = _i6(m30, m21, m12, m03)
        I7 = (
            (3 * m21 + 2 * m03) * _p3(m12)
            + 3 * m30 * (m03 + 2 * m21) * _p2(m12)
            - 3 * m21 * (m30 + m03 + m21) * (-m30 + m03 + m21) * m12
            + m30 * (-_p2(m30) * m03 - 2 * _p3(m21) - 3 * m03 * _p2(m21) + _p3(m03))
        )
        I9 = _p2(_p2(m03) + 3 * m03 * m21 + m30 * (m30 + 3 * m12))
        out[0] = I7 / I6
        out[1] = I9 / I6
        return out
    c1 = m20 - m02
    s1 = 2 * m11
    c2 = m03 - 3 * m21
    s2 = m30 - 3 * m12
    I1 = _p2(c1) + _p2(s1)
    I3 = m20 + m02
    if kind == 1:
        I2 = _p2(c2) + _p2(s2)
        out[0] = I1 / _p2(I3)
        out[1] = I2 / _p3(I3)
        return out
    c3 = _p2(c1) - _p2(s1)
    s3 = 2 * s1 * c1
    r3 = np.sqrt(I3)
    K = I1 * (I3 * r3) / r3  # I1 I3^(3/2) / sqrt(I3)
    out[0] = (c2 * c3 + s2 * s3) / K
    out[1] = (s2 * c3 - c2 * s3) / K
    return out


@kernel
def _inv_inputs(mu: Any) -> Any:
    x = np.empty(7)
    for k in range(7):
        x[k] = mu[INV_KEYS[k][0], INV_KEYS[k][1]]
    return x


@kernel
def check_moments(mu: Any, kind: int) -> Any:
    """``(code, value)``: COINCIDE, ISOTROPIC, SYMMETRIC or I6_ZERO where the features are
    undefined or singular (0: valid)."""
    I3 = mu[2, 0] + mu[0, 2]
    if not I3 > 0.0:
        return COINCIDE, 0.0
    delta = math.hypot(mu[2, 0] - mu[0, 2], 2.0 * mu[1, 1])
    if delta <= ISOTROPY_TOL * I3:
        return ISOTROPIC, 0.0
    if kind == 0 or kind == 1:
        t3 = math.sqrt(mu[3, 0] ** 2 + mu[2, 1] ** 2 + mu[1, 2] ** 2 + mu[0, 3] ** 2)
        if t3 <= SYMMETRY_TOL * I3**1.5:
            return SYMMETRIC, 0.0
        if kind == 0:
            I6 = _i6(mu[3, 0], mu[2, 1], mu[1, 2], mu[0, 3])
            if I6 <= I6_TOL * _p4(t3):
                return I6_ZERO, 0.0
    return OK, 0.0


@kernel
def moment_features(
    xg: float, yg: float, mu: Any, area_star: float, depth_star: float, kind: int
) -> Any:
    """``s = (xn, yn, an, α, r1, r2)`` (6,) (features/moments.py); moments checked before."""
    a = mu[2, 0] + mu[0, 2]
    an = depth_star * np.sqrt(area_star / a)
    alpha = 0.5 * math.atan2(2.0 * mu[1, 1], mu[2, 0] - mu[0, 2])
    r = rotation_invariants(_inv_inputs(mu), kind)
    s = np.empty(6)
    s[0] = an * xg
    s[1] = an * yg
    s[2] = an
    s[3] = alpha
    s[4] = r[0]
    s[5] = r[1]
    return s


@kernel
def moment_measure(pts: Any, cMo: Any, area_star: float, depth_star: float, kind: int) -> Any:
    """Measure the features of N coplanar points (N, 3) of the object frame at ``cMo``.

    Returns:
        ``(s, plane, xg, yg, mu, code, value)``; ``code`` BEHIND (value: the point index,
        then ``s[0]`` holds its depth), or a code of :func:`fit_plane` or
        :func:`check_moments` (0: valid).
    """
    n = pts.shape[0]
    P = np.empty((n, 3))
    xy = np.empty((n, 2))
    for k in range(n):
        for r in range(3):
            P[k, r] = (
                cMo[r, 0] * pts[k, 0] + cMo[r, 1] * pts[k, 1] + cMo[r, 2] * pts[k, 2] + cMo[r, 3]
            )
    s = np.zeros(6)
    mu = np.zeros((ORDER + 1, ORDER + 1))
    for k in range(n):
        if P[k, 2] <= MIN_DEPTH:
            s[0] = P[k, 2]
            return s, np.zeros(3), 0.0, 0.0, mu, BEHIND, float(k)
        xy[k, 0] = P[k, 0] / P[k, 2]
        xy[k, 1] = P[k, 1] / P[k, 2]
    xg, yg, mu = image_moments(xy)
    plane, code, value = fit_plane(P)
    if code != OK:
        return s, plane, xg, yg, mu, code, value
    code, value = check_moments(mu, kind)
    if code != OK:
        return s, plane, xg, yg, mu, code, value
    return moment_features(xg, yg, mu, area_star, depth_star, kind), plane, xg, yg, mu, OK, 0.0
