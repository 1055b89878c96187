"""Feature kernels: points, lines, cylinders and spheres (values and interaction matrices).

Formulas, conventions and decisions are documented in :mod:`redservo.features.point`,
:mod:`~redservo.features.line` and :mod:`~redservo.features.sphere`, which wrap these
kernels. Normalized image coordinates; ``L`` with ``ṡ = L v_c``. A kernel that can fail
returns an integer code (0: valid) and the number the error message needs; the Python
layer raises :class:`~redservo.errors.GeometryError` with the message.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.points import camera_point, point_interaction_into

__all__ = [
    "cylinder_interaction",
    "cylinder_lines",
    "ellipse_moment_interaction",
    "line_interaction",
    "point_interaction",
    "points_interaction",
    "points_measure",
    "project_line",
    "project_point",
    "sphere_ellipse",
    "sphere_interaction",
    "sphere_moments_from_area",
    "sphere_paper_interaction",
    "wrap_angle",
]

MIN_DEPTH = 1e-6
"""Same as :data:`redservo.camera.MIN_DEPTH` (m)."""
PARALLEL_TOL = 1e-9
OK, BEHIND, ZERO_AXIS, THROUGH_CENTRE, PARALLEL_BEHIND, AT_INFINITY, INSIDE, NOT_IN_FRONT = range(8)
"""Codes of the failing kernels (the messages are in the feature modules)."""


@kernel
def wrap_angle(a: float) -> float:
    """Wrap an angle (rad) to (-π, π]: ``π - mod(π - a, 2π)``."""
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


@kernel
def point_interaction(x: float, y: float, inv_z: float) -> Any:
    """(2, 6) interaction matrix of a normalized image point (CM01 eq. 26)."""
    L = np.empty((2, 6))
    point_interaction_into(x, y, inv_z, L, 0)
    return L


@kernel
def project_point(X: float, Y: float, Z: float) -> Any:
    """``(x, y, 1/Z, ok)`` of a camera-frame point; ``ok`` False when ``Z <= MIN_DEPTH``."""
    if Z <= MIN_DEPTH:
        return 0.0, 0.0, 0.0, False
    return X / Z, Y / Z, 1.0 / Z, True


@kernel
def points_measure(cMo: Any, pts: Any) -> Any:
    """``(s, 1/Z, bad)`` of N points (N, 3) of the object frame seen at ``cMo``: s (2N,) the
    stacked ``(x, y)``, 1/Z (N,), and the first point at or behind the camera (-1 if none)."""
    n = pts.shape[0]
    s = np.empty(2 * n)
    iz = np.empty(n)
    bad = -1
    for k in range(n):
        X, Y, Z = camera_point(cMo, pts, k)
        if Z <= MIN_DEPTH:
            if bad < 0:
                bad = k
            Z = 1.0
        s[2 * k] = X / Z
        s[2 * k + 1] = Y / Z
        iz[k] = 1.0 / Z
    return s, iz, bad


@kernel
def points_interaction(s: Any, inv_z: Any) -> Any:
    """(2N, 6) stacked interaction matrices of N points ``s = (x1, y1, x2, ...)``."""
    n = inv_z.shape[0]
    L = np.empty((2 * n, 6))
    for k in range(n):
        point_interaction_into(s[2 * k], s[2 * k + 1], inv_z[k], L, 2 * k)
    return L


@kernel
def line_interaction(rho: float, theta: float, plane: Any) -> Any:
    """(2, 6) interaction matrix of an image line ``(ρ, θ)`` with ``(A, B, C)/D = plane``."""
    a = plane[0]
    b = plane[1]
    c = plane[2]
    ct = math.cos(theta)
    st = math.sin(theta)
    lr = a * rho * ct + b * rho * st + c
    lt = a * st - b * ct
    r2 = 1.0 + rho * rho
    L = np.empty((2, 6))
    L[0, 0] = lr * ct
    L[0, 1] = lr * st
    L[0, 2] = -lr * rho
    L[0, 3] = r2 * st
    L[0, 4] = -r2 * ct
    L[0, 5] = 0.0
    L[1, 0] = lt * ct
    L[1, 1] = lt * st
    L[1, 2] = -lt * rho
    L[1, 3] = -rho * ct
    L[1, 4] = -rho * st
    L[1, 5] = -1.0
    return L


@kernel
def _cross(a: Any, b: Any) -> Any:
    out = np.empty(3)
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


@kernel
def _norm3(v: Any) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@kernel
def _image_line(n: Any) -> Any:
    """``(ρ, θ, ok)`` of the image of the interpretation plane ``n · X = 0``."""
    nu = math.hypot(n[0], n[1])
    if nu <= PARALLEL_TOL * _norm3(n):
        return 0.0, 0.0, False
    return -n[2] / nu, wrap_angle(math.atan2(n[1], n[0])), True


@kernel
def project_line(P0: Any, u_in: Any) -> Any:
    """``(ρ, θ, plane, code, value)`` of the 3-D line through ``P0`` along ``u`` (camera
    frame); ``value`` is the distance to the optical centre (code THROUGH_CENTRE) or the
    depth (PARALLEL_BEHIND)."""
    plane = np.zeros(3)
    nu = _norm3(u_in)
    if nu < 1e-12:
        return 0.0, 0.0, plane, ZERO_AXIS, 0.0
    u = u_in / nu
    up = u[0] * P0[0] + u[1] * P0[1] + u[2] * P0[2]
    perp = P0 - up * u
    d2 = perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2]
    if d2 <= MIN_DEPTH**2:
        return 0.0, 0.0, plane, THROUGH_CENTRE, math.sqrt(d2)
    if abs(u[2]) < PARALLEL_TOL and perp[2] <= MIN_DEPTH:
        return 0.0, 0.0, plane, PARALLEL_BEHIND, perp[2]
    rho, theta, ok = _image_line(_cross(P0, u))
    if not ok:
        return 0.0, 0.0, plane, AT_INFINITY, 0.0
    for i in range(3):
        plane[i] = -perp[i] / d2
    return rho, theta, plane, OK, 0.0


@kernel
def cylinder_lines(R: float, a_in: Any, X0_in: Any) -> Any:
    """``(s, plane, code, value)``: the two limb lines ``(ρ1, θ1, ρ2, θ2)`` of a cylinder and
    the polar plane (docs/formulas.md §3.2); codes ZERO_AXIS, INSIDE (value: distance to the
    axis), PARALLEL_BEHIND (value: depth), AT_INFINITY (value: limb number)."""
    s = np.zeros(4)
    plane = np.zeros(3)
    na = _norm3(a_in)
    if na < 1e-12:
        return s, plane, ZERO_AXIS, 0.0
    a = a_in / na
    ax = a[0] * X0_in[0] + a[1] * X0_in[1] + a[2] * X0_in[2]
    X0 = X0_in - ax * a
    d = _norm3(X0)
    if d - R <= MIN_DEPTH:
        return s, plane, INSIDE, d
    D = d * d - R * R
    sc = 1.0 / np.sqrt(D)
    w = _cross(X0, a)
    if abs(a[2]) < PARALLEL_TOL:  # contour generators parallel to the image plane
        k = _cross(a, X0)
        for sign in (1.0, -1.0):
            Tz = (1.0 - R * R / (d * d)) * X0[2] + sign * (R * np.sqrt(D) / (d * d)) * k[2]
            if Tz <= MIN_DEPTH:
                return s, plane, PARALLEL_BEHIND, Tz
    rho1, theta1, ok1 = _image_line(R * sc * X0 - w)
    if not ok1:
        return s, plane, AT_INFINITY, 1.0
    rho2, theta2, ok2 = _image_line(R * sc * X0 + w)
    if not ok2:
        return s, plane, AT_INFINITY, 2.0
    s[0] = rho1
    s[1] = theta1
    s[2] = rho2
    s[3] = theta2
    for i in range(3):
        plane[i] = -X0[i] / D
    return s, plane, OK, 0.0


@kernel
def cylinder_interaction(s: Any, plane: Any) -> Any:
    """(4, 6): both limbs ``(ρ1, θ1, ρ2, θ2)`` with the polar plane."""
    L = np.empty((4, 6))
    L[0:2] = line_interaction(s[0], s[1], plane)
    L[2:4] = line_interaction(s[2], s[3], plane)
    return L


@kernel
def sphere_ellipse(r: float, X: float, Y: float, Z: float) -> Any:
    """``(xc, yc, a, n20, n11, n02, plane, code, value)`` of a sphere's image (A3); codes
    INSIDE (value: centre distance) and NOT_IN_FRONT (value: centre depth)."""
    plane = np.zeros(3)
    dist = math.sqrt(X * X + Y * Y + Z * Z)
    if dist - r <= MIN_DEPTH:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, plane, INSIDE, dist
    if Z - r <= MIN_DEPTH:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, plane, NOT_IN_FRONT, Z
    m = Z * Z - r * r
    k = dist * dist - r * r
    r2 = r * r
    plane[0] = X / k
    plane[1] = Y / k
    plane[2] = Z / k
    return (
        X * Z / m,
        Y * Z / m,
        np.pi * r2 * np.sqrt(k) / m**1.5,
        r2 * (m + X * X) / (4.0 * m * m),
        r2 * X * Y / (4.0 * m * m),
        r2 * (m + Y * Y) / (4.0 * m * m),
        plane,
        OK,
        0.0,
    )


@kernel
def sphere_moments_from_area(xc: float, yc: float, area: float) -> Any:
    """``(n20, n11, n02)`` of a sphere's ellipse from its centre and area (Newton on the cubic
    of features/sphere.py)."""
    alpha2 = (area / np.pi) ** 2
    c2 = 1.0 + xc * xc + yc * yc
    beta = abs(area) / np.pi
    for _ in range(100):
        f = ((beta + c2) * beta - alpha2) * beta - alpha2
        fp = (3.0 * beta + 2.0 * c2) * beta - alpha2
        if fp <= 0.0:
            break
        step = f / fp
        beta -= step
        if abs(step) <= 4.0 * 2.220446049250313e-16 * beta:
            break
    g = beta / (1.0 + beta)
    return 0.25 * (beta + g * xc * xc), 0.25 * g * xc * yc, 0.25 * (beta + g * yc * yc)


@kernel
def _centre_rows(
    xc: float, yc: float, n20: float, n11: float, n02: float, plane: Any, L: Any
) -> float:
    """Fill ``L[0:2]`` with ``[L_xc; L_yc]`` (Chaumette 2004 eq. 14); return ``1/Zg``."""
    A = plane[0]
    B = plane[1]
    C = plane[2]
    izg = A * xc + B * yc + C
    L[0, 0] = -izg
    L[0, 1] = 0.0
    L[0, 2] = xc * izg + 4.0 * (A * n20 + B * n11)
    L[0, 3] = xc * yc + 4.0 * n11
    L[0, 4] = -(1.0 + xc * xc + 4.0 * n20)
    L[0, 5] = yc
    L[1, 0] = 0.0
    L[1, 1] = -izg
    L[1, 2] = yc * izg + 4.0 * (A * n11 + B * n02)
    L[1, 3] = 1.0 + yc * yc + 4.0 * n02
    L[1, 4] = -xc * yc - 4.0 * n11
    L[1, 5] = -xc
    return izg


@kernel
def sphere_interaction(s: Any, plane: Any) -> Any:
    """Exact (3, 6) interaction matrix of ``s = (xc, yc, a)`` (A3)."""
    xc = s[0]
    yc = s[1]
    a = s[2]
    n20, n11, n02 = sphere_moments_from_area(xc, yc, a)
    L = np.empty((3, 6))
    izg = _centre_rows(xc, yc, n20, n11, n02, plane, L)
    L[2, 0] = -a * plane[0]
    L[2, 1] = -a * plane[1]
    L[2, 2] = a * (3.0 * izg - plane[2])
    L[2, 3] = 3.0 * a * yc
    L[2, 4] = -3.0 * a * xc
    L[2, 5] = 0.0
    return L


@kernel
def sphere_paper_interaction(s: Any, plane: Any) -> Any:
    """CM01 eq. 27 (3, 6) at ``s = (xc, yc, a)``: ``R² = a/π``, ``1/z_d = C/(1 + R²)``."""
    R2 = s[2] / np.pi
    iz = plane[2] / (1.0 + R2)
    L = np.zeros((3, 6))
    L[0, 0] = -iz
    L[0, 4] = -(1.0 + R2)
    L[1, 1] = -iz
    L[1, 3] = 1.0 + R2
    L[2, 2] = np.pi * R2 * iz
    return L


@kernel
def ellipse_moment_interaction(s: Any, plane: Any) -> Any:
    """Exact (5, 6) interaction matrix of ``s = (xc, yc, n20, n11, n02)`` (Chaumette 2004)."""
    xc = s[0]
    yc = s[1]
    n20 = s[2]
    n11 = s[3]
    n02 = s[4]
    A = plane[0]
    B = plane[1]
    C = plane[2]
    L = np.empty((5, 6))
    izg = _centre_rows(xc, yc, n20, n11, n02, plane, L)
    L[2, 0] = -2.0 * (A * n20 + B * n11)
    L[2, 1] = 0.0
    L[2, 2] = 2.0 * ((izg + A * xc) * n20 + B * xc * n11)
    L[2, 3] = 2.0 * (yc * n20 + xc * n11)
    L[2, 4] = -4.0 * n20 * xc
    L[2, 5] = 2.0 * n11
    L[3, 0] = -A * n11 - B * n02
    L[3, 1] = -A * n20 - B * n11
    L[3, 2] = A * yc * n20 + (3.0 * izg - C) * n11 + B * xc * n02
    L[3, 3] = 3.0 * yc * n11 + xc * n02
    L[3, 4] = -yc * n20 - 3.0 * xc * n11
    L[3, 5] = n02 - n20
    L[4, 0] = 0.0
    L[4, 1] = -2.0 * (A * n11 + B * n02)
    L[4, 2] = 2.0 * ((izg + B * yc) * n02 + A * yc * n11)
    L[4, 3] = 4.0 * yc * n02
    L[4, 4] = -2.0 * (yc * n11 + xc * n02)
    L[4, 5] = -2.0 * n11
    return L
