"""Kernels of the interaction matrices of the decoupled moment features (Tahri & Chaumette 2005).

The moments and features themselves are measured by :mod:`redservo.kernels.moments` (its
docstring: the ``mu`` layout and the ``kind`` codes). Rows are over the camera velocity
``(v, ω)`` (m/s, rad/s); ``plane = (A, B, C)`` is the object plane ``1/Z = A x + B y + C``
(1/m).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.moments import INV_KEYS, _inv_inputs, rotation_invariants

__all__ = ["centred_moment_row", "centroid_rows", "moment_features_interaction"]


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
    xc = x.astype(np.complex128)  # one work array: each step moves one entry, then resets it
    for k in range(7):
        xc[k] += 1j * h
        r = rotation_invariants(xc, kind)
        xc[k] = x[k]
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
