"""Kernels of the decoupled moment features of coplanar points (Tahri & Chaumette 2005).

Definitions, interaction matrices and decisions: :mod:`redservo.features.moments`, which
wraps these kernels. Moments are held as a (5, 5) array ``mu[i, j] = μ_ij`` (``i + j <= 4``)
with the centroid ``(xg, yg)``; ``kind`` selects the rotation features: 0 ``"c4c6"``,
1 ``"pxpy"``, 2 ``"sxsy"``. Derivatives of the rotation features use complex steps, so
:func:`rotation_invariants` is compiled for real and for complex input from one source.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.lapack import gesvd

__all__ = [
    "centred_moment_row",
    "centroid_rows",
    "check_moments",
    "fit_plane",
    "image_moments",
    "moment_features",
    "moment_features_interaction",
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
    _, sv, V, _ = gesvd(Q)
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
def _m(mu: Any, p: int, q: int) -> float:
    return mu[p, q] if p >= 0 and q >= 0 else 0.0


@kernel
def centred_moment_row(
    i: int, j: int, mu: Any, xg: float, yg: float, plane: Any, delta: int, eps: float
) -> Any:
    """Interaction row ``L_μij`` (6,) of a centred moment (points: δ = 0, ε = 1)."""
    A = plane[0]
    B = plane[1]
    C = plane[2]
    m00 = _m(mu, 0, 0)
    n20 = _m(mu, 2, 0) / m00
    n11 = _m(mu, 1, 1) / m00
    n02 = _m(mu, 0, 2) / m00
    d = delta
    row = np.empty(6)
    vx = -(i + d) * A * _m(mu, i, j) - i * B * _m(mu, i - 1, j + 1)
    vy = -j * A * _m(mu, i + 1, j - 1) - (j + d) * B * _m(mu, i, j)
    wx = (
        (i + j + 3 * d) * _m(mu, i, j + 1)
        + (i + 2 * j + 3 * d) * yg * _m(mu, i, j)
        + i * xg * _m(mu, i - 1, j + 1)
        - i * eps * n11 * _m(mu, i - 1, j)
        - j * eps * n02 * _m(mu, i, j - 1)
    )
    wy = (
        -(i + j + 3 * d) * _m(mu, i + 1, j)
        - (2 * i + j + 3 * d) * xg * _m(mu, i, j)
        - j * yg * _m(mu, i + 1, j - 1)
        + i * eps * n20 * _m(mu, i - 1, j)
        + j * eps * n11 * _m(mu, i, j - 1)
    )
    row[0] = vx
    row[1] = vy
    row[2] = -A * wy + B * wx + (i + j + 2 * d) * C * _m(mu, i, j)
    row[3] = wx
    row[4] = wy
    row[5] = i * _m(mu, i - 1, j + 1) - j * _m(mu, i + 1, j - 1)
    return row


@kernel
def centroid_rows(n: int, xg: float, yg: float, mu: Any, plane: Any) -> Any:
    """``[L_xg; L_yg]`` (2, 6) of the centroid of N points."""
    A = plane[0]
    B = plane[1]
    C = plane[2]
    n20 = mu[2, 0] / n
    n11 = mu[1, 1] / n
    n02 = mu[0, 2] / n
    izg = A * xg + B * yg + C
    L = np.empty((2, 6))
    L[0, 0] = -izg
    L[0, 1] = 0.0
    L[0, 2] = xg * izg + A * n20 + B * n11
    L[0, 3] = xg * yg + n11
    L[0, 4] = -(1.0 + xg * xg + n20)
    L[0, 5] = yg
    L[1, 0] = 0.0
    L[1, 1] = -izg
    L[1, 2] = yg * izg + A * n11 + B * n02
    L[1, 3] = 1.0 + yg * yg + n02
    L[1, 4] = -(xg * yg + n11)
    L[1, 5] = -xg
    return L


@kernel
def moment_features_interaction(
    n: int,
    xg: float,
    yg: float,
    mu: Any,
    plane: Any,
    area_star: float,
    depth_star: float,
    kind: int,
) -> Any:
    """(6, 6) interaction matrix of ``(xn, yn, an, α, r1, r2)`` for a general plane (chain
    rule on ``L_μij``; ``∂r/∂μ`` by complex steps of ``h = 1e-30``)."""
    Lmu = np.empty((7, 6))
    for k in range(7):
        Lmu[k] = centred_moment_row(INV_KEYS[k][0], INV_KEYS[k][1], mu, xg, yg, plane, 0, 1.0)
    a = mu[2, 0] + mu[0, 2]
    an = depth_star * np.sqrt(area_star / a)
    Lg = centroid_rows(n, xg, yg, mu, plane)
    c1 = mu[2, 0] - mu[0, 2]
    Delta = c1 * c1 + 4.0 * mu[1, 1] ** 2
    f = -an / (2.0 * a)
    x = _inv_inputs(mu)
    grad = np.empty((2, 7))
    h = 1e-30
    for k in range(7):
        xc = x.astype(np.complex128)
        xc[k] += 1j * h
        r = rotation_invariants(xc, kind)
        grad[0, k] = r[0].imag / h
        grad[1, k] = r[1].imag / h
    L = np.empty((6, 6))
    for c in range(6):
        l_an = f * (Lmu[0, c] + Lmu[2, c])
        L[0, c] = an * Lg[0, c] + xg * l_an
        L[1, c] = an * Lg[1, c] + yg * l_an
        L[2, c] = l_an
        L[3, c] = (c1 * Lmu[1, c] - mu[1, 1] * (Lmu[0, c] - Lmu[2, c])) / Delta
        for r_ in range(2):
            acc = 0.0
            for k in range(7):
                acc += grad[r_, k] * Lmu[k, c]
            L[4 + r_, c] = acc
    return L


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
