"""Compiled signed distances between primitive pairs, for the campaign loop.

Every robot link is a capsule (a segment ``a0 a1`` and a radius, m; a sphere is a capsule
whose segment has zero length), so the pairs are capsule against capsule, plane and box.
Each kernel returns ``(d, wa, wb)``: the signed distance (m, negative when the shapes
overlap: minus the penetration depth) and the witness points on the capsule (``wa``) and on
the other shape (``wb``), world frame. :func:`redservo.collision.distances` (coal) is the
reference these are tested against (tests/test_collision_kernels.py).

* capsule/capsule: the closest points of two segments (Ericson, *Real-Time Collision
  Detection*, §5.1.9), exact;
* capsule/plane: the lower end of the segment, exact;
* capsule/box and capsule/cylinder: the signed distance of a point to a convex solid is
  convex, hence so is its value along the segment: a golden-section search of the segment
  parameter (:data:`GOLDEN_ITERATIONS` steps, interval below 1e-16 of the segment), then the
  point's distance, exact for it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = [
    "GOLDEN_ITERATIONS",
    "capsule_box",
    "capsule_capsule",
    "capsule_cylinder",
    "capsule_plane",
    "segments",
]

GOLDEN_ITERATIONS = 90
_EPS = 1e-300


@kernel
def _clamp01(x: float) -> float:
    return min(max(x, 0.0), 1.0)


@kernel
def segments(p1: Any, q1: Any, p2: Any, q2: Any) -> Any:
    """``(s, t)``: parameters of the closest points ``p1 + s (q1 − p1)``, ``p2 + t (q2 − p2)``."""
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    a = np.dot(d1, d1)
    e = np.dot(d2, d2)
    f = np.dot(d2, r)
    if a <= 1e-24 and e <= 1e-24:
        return 0.0, 0.0
    if a <= 1e-24:
        return 0.0, _clamp01(f / e)
    c = np.dot(d1, r)
    if e <= 1e-24:
        return _clamp01(-c / a), 0.0
    b = np.dot(d1, d2)
    denom = a * e - b * b
    s = _clamp01((b * f - c * e) / denom) if denom > 1e-24 * a * e else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        return _clamp01(-c / a), 0.0
    if t > 1.0:
        return _clamp01((b - c) / a), 1.0
    return s, t


@kernel
def _fallback_normal(d: Any) -> Any:
    """A unit vector normal to ``d`` (or x when ``d`` is zero), for coincident points."""
    n = np.array([1.0, 0.0, 0.0])
    if abs(d[0]) > 0.9 * np.sqrt(np.dot(d, d)) and np.dot(d, d) > 0.0:
        n = np.array([0.0, 1.0, 0.0])
    n = n - (np.dot(n, d) / max(np.dot(d, d), _EPS)) * d
    return n / np.sqrt(np.dot(n, n))


@kernel
def capsule_capsule(a0: Any, a1: Any, ra: float, b0: Any, b1: Any, rb: float) -> Any:
    """Capsule ``(a0, a1, ra)`` against capsule ``(b0, b1, rb)`` (module docstring)."""
    s, t = segments(a0, a1, b0, b1)
    ca = a0 + s * (a1 - a0)
    cb = b0 + t * (b1 - b0)
    v = cb - ca
    dist = np.sqrt(np.dot(v, v))
    n = v / dist if dist > 1e-15 else _fallback_normal(a1 - a0)
    return dist - ra - rb, ca + ra * n, cb - rb * n


@kernel
def capsule_plane(a0: Any, a1: Any, r: float, point: Any, normal: Any) -> Any:
    """Capsule against the half-space below the plane through ``point`` with unit ``normal``."""
    h0 = np.dot(a0 - point, normal)
    h1 = np.dot(a1 - point, normal)
    c = a0 if h0 <= h1 else a1
    h = min(h0, h1)
    return h - r, c - r * normal, c - h * normal


@kernel
def _point_box(p: Any, R: Any, t: Any, half: Any) -> Any:
    """Signed distance (m) of ``p`` to the box ``(R, t, half extents)`` and its nearest point."""
    local = R.T @ (p - t)
    inside = True
    for k in range(3):
        if abs(local[k]) > half[k]:
            inside = False
    near = np.empty(3)
    if not inside:
        for k in range(3):
            near[k] = min(max(local[k], -half[k]), half[k])
        v = local - near
        return np.sqrt(np.dot(v, v)), R @ near + t
    best = 0
    depth = half[0] - abs(local[0])
    for k in range(1, 3):
        if half[k] - abs(local[k]) < depth:
            depth = half[k] - abs(local[k])
            best = k
    near[:] = local
    near[best] = half[best] if local[best] >= 0.0 else -half[best]
    return -depth, R @ near + t


@kernel
def _point_cylinder(p: Any, R: Any, t: Any, size: Any) -> Any:
    """Signed distance (m) of ``p`` to the cylinder ``(R, t)`` of radius ``size[0]`` and axis
    length ``size[1]`` (along its z, centred), and its nearest point."""
    local = R.T @ (p - t)
    radius, h = size[0], 0.5 * size[1]
    rho = np.sqrt(local[0] * local[0] + local[1] * local[1])
    dr, dz = rho - radius, abs(local[2]) - h
    near = local.copy()
    if dr <= 0.0 and dz <= 0.0:  # inside: the nearer of the side and the caps
        if dz >= dr:
            near[2] = h if local[2] >= 0.0 else -h
            return dz, R @ near + t
        ux, uy = (local[0] / rho, local[1] / rho) if rho > 1e-15 else (1.0, 0.0)
        near[0], near[1] = radius * ux, radius * uy
        return dr, R @ near + t
    if dr > 0.0:
        near[0], near[1] = local[0] * (radius / rho), local[1] * (radius / rho)
    if dz > 0.0:
        near[2] = h if local[2] >= 0.0 else -h
    v = local - near
    return np.sqrt(np.dot(v, v)), R @ near + t


@kernel
def _point_solid(p: Any, R: Any, t: Any, size: Any, cylinder: bool) -> Any:
    """:func:`_point_box` (``size`` the half extents) or :func:`_point_cylinder`."""
    if cylinder:
        return _point_cylinder(p, R, t, size)
    return _point_box(p, R, t, size)


@kernel
def _box_gap(local: Any, half: Any, v: Any) -> float:
    """The distance of :func:`_point_box` from ``local = Rᵀ (p − t)``, by the same
    operations (m); ``v`` (3,) is scratch."""
    inside = True
    for k in range(3):
        if abs(local[k]) > half[k]:
            inside = False
    if not inside:
        for k in range(3):
            v[k] = local[k] - min(max(local[k], -half[k]), half[k])
        return np.sqrt(np.dot(v, v))
    depth = half[0] - abs(local[0])
    for k in range(1, 3):
        if half[k] - abs(local[k]) < depth:
            depth = half[k] - abs(local[k])
    return -depth


@kernel
def _cylinder_gap(local: Any, size: Any, v: Any) -> float:
    """The distance of :func:`_point_cylinder` from ``local = Rᵀ (p − t)``, by the same
    operations (m); ``v`` (3,) is scratch."""
    radius, h = size[0], 0.5 * size[1]
    rho = np.sqrt(local[0] * local[0] + local[1] * local[1])
    dr, dz = rho - radius, abs(local[2]) - h
    if dr <= 0.0 and dz <= 0.0:
        return dz if dz >= dr else dr
    v[:] = 0.0
    if dr > 0.0:
        v[0] = local[0] - local[0] * (radius / rho)
        v[1] = local[1] - local[1] * (radius / rho)
    if dz > 0.0:
        v[2] = local[2] - (h if local[2] >= 0.0 else -h)
    return np.sqrt(np.dot(v, v))


@kernel
def _gap(x: float, a0: Any, ab: Any, R: Any, t: Any, size: Any, cylinder: bool, w: Any) -> float:
    """``_point_solid(a0 + x ab, …)[0]`` without the nearest point: the search's objective,
    element for element the operations of the full form; ``w`` (2, 3) is scratch."""
    for k in range(3):
        w[0, k] = (a0[k] + x * ab[k]) - t[k]
    local = R.T @ w[0]
    if cylinder:
        return _cylinder_gap(local, size, w[1])
    return _box_gap(local, size, w[1])


@kernel
def _capsule_solid(a0: Any, a1: Any, r: float, M: Any, size: Any, cylinder: bool) -> Any:
    """Capsule against a convex solid (module docstring): golden section on the segment."""
    R = np.ascontiguousarray(M[:3, :3])
    t = np.ascontiguousarray(M[:3, 3])
    ab = a1 - a0  # the same difference at every point: the iterates of the full form
    w = np.empty((2, 3))
    g = 0.5 * (np.sqrt(5.0) - 1.0)
    lo, hi = 0.0, 1.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1 = _gap(x1, a0, ab, R, t, size, cylinder, w)
    f2 = _gap(x2, a0, ab, R, t, size, cylinder, w)
    for _ in range(GOLDEN_ITERATIONS):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = _gap(x1, a0, ab, R, t, size, cylinder, w)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = _gap(x2, a0, ab, R, t, size, cylinder, w)
    best_s = 0.5 * (lo + hi)
    best_f = _gap(best_s, a0, ab, R, t, size, cylinder, w)
    for s in (0.0, 1.0):  # the minimum may sit on an end
        f = _gap(s, a0, ab, R, t, size, cylinder, w)
        if f < best_f:
            best_s, best_f = s, f
    c = a0 + best_s * (a1 - a0)
    d, near = _point_solid(c, R, t, size, cylinder)
    v = near - c
    norm = np.sqrt(np.dot(v, v))
    n = v / norm if norm > 1e-15 else _fallback_normal(a1 - a0)
    if d < 0.0:
        n = -n  # inside: the nearest face is away from the outward direction
    return d - r, c + r * n, near


@kernel
def capsule_box(a0: Any, a1: Any, r: float, M: Any, half: Any) -> Any:
    """Capsule against the box of pose ``M`` (4x4) and half extents ``half`` (3,)."""
    return _capsule_solid(a0, a1, r, M, half, False)


@kernel
def capsule_cylinder(a0: Any, a1: Any, r: float, M: Any, size: Any) -> Any:
    """Capsule against the cylinder of pose ``M`` (4x4), ``size = (radius, length, 0)`` (m;
    the axis along the cylinder's z, centred on its origin)."""
    return _capsule_solid(a0, a1, r, M, size, True)
