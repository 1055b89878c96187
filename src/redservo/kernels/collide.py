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
  point's distance, exact for it. The search's objective is scalar code: the products that
  numpy hands to BLAS (``Rᵀ w``, ``v·v``) are written out as the fused multiply-add chains
  OpenBLAS computes them with (:mod:`redservo.kernels.fma`), so the iterates and the result
  are the BLAS form's to the bit (tests/test_collision_fma.py), at about 2 µs per
  capsule/cylinder pair instead of 14.

:func:`segment_distance` is the capsule/capsule distance in scalars (no temporary array)
for the broad phase's lower bounds (:mod:`redservo.kernels.loop_cull`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.fma import rtw3, sq3

__all__ = [
    "GOLDEN_ITERATIONS",
    "capsule_box",
    "capsule_capsule",
    "capsule_cylinder",
    "capsule_plane",
    "segment_distance",
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
def segment_distance(p1: Any, q1: Any, p2: Any, q2: Any) -> float:
    """The distance (m) between the closest points of :func:`segments`, computed in
    scalars (no temporary array; the same branches, rounded differently in the last bits)."""
    a = e = f = c = b = 0.0
    for k in range(3):
        d1, d2, r = q1[k] - p1[k], q2[k] - p2[k], p1[k] - p2[k]
        a, e, f, c, b = a + d1 * d1, e + d2 * d2, f + d2 * r, c + d1 * r, b + d1 * d2
    s = t = 0.0
    if a <= 1e-24 and e > 1e-24:
        t = _clamp01(f / e)
    elif a > 1e-24 and e <= 1e-24:
        s = _clamp01(-c / a)
    elif a > 1e-24:
        denom = a * e - b * b
        s = _clamp01((b * f - c * e) / denom) if denom > 1e-24 * a * e else 0.0
        t = (b * s + f) / e
        if t < 0.0:
            s, t = _clamp01(-c / a), 0.0
        elif t > 1.0:
            s, t = _clamp01((b - c) / a), 1.0
    acc = 0.0
    for k in range(3):
        v = (p2[k] + t * (q2[k] - p2[k])) - (p1[k] + s * (q1[k] - p1[k]))
        acc += v * v
    return np.sqrt(acc)


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
def _box_gap(l0: float, l1: float, l2: float, half: Any) -> float:
    """The distance of :func:`_point_box` from ``(l0, l1, l2) = Rᵀ (p − t)``, by the same
    operations (m)."""
    if abs(l0) > half[0] or abs(l1) > half[1] or abs(l2) > half[2]:
        v0 = l0 - min(max(l0, -half[0]), half[0])
        v1 = l1 - min(max(l1, -half[1]), half[1])
        v2 = l2 - min(max(l2, -half[2]), half[2])
        return np.sqrt(sq3(v0, v1, v2))
    depth = half[0] - abs(l0)
    if half[1] - abs(l1) < depth:
        depth = half[1] - abs(l1)
    if half[2] - abs(l2) < depth:
        depth = half[2] - abs(l2)
    return -depth


@kernel
def _cylinder_gap(l0: float, l1: float, l2: float, size: Any) -> float:
    """The distance of :func:`_point_cylinder` from ``(l0, l1, l2) = Rᵀ (p − t)``, by the
    same operations (m)."""
    radius, h = size[0], 0.5 * size[1]
    rho = np.sqrt(l0 * l0 + l1 * l1)
    dr, dz = rho - radius, abs(l2) - h
    if dr <= 0.0 and dz <= 0.0:
        return dz if dz >= dr else dr
    v0 = v1 = v2 = 0.0
    if dr > 0.0:
        v0 = l0 - l0 * (radius / rho)
        v1 = l1 - l1 * (radius / rho)
    if dz > 0.0:
        v2 = l2 - (h if l2 >= 0.0 else -h)
    return np.sqrt(sq3(v0, v1, v2))


@kernel
def _gap(x: float, a0: Any, ab: Any, R: Any, t: Any, size: Any, cylinder: bool) -> float:
    """``_point_solid(a0 + x ab, …)[0]`` without the nearest point: the search's objective,
    element for element the operations of the full form, its BLAS products (``Rᵀ w``,
    ``v·v``) written out as OpenBLAS computes them (:mod:`redservo.kernels.fma`), in
    scalars (no temporary array)."""
    w0 = (a0[0] + x * ab[0]) - t[0]
    w1 = (a0[1] + x * ab[1]) - t[1]
    w2 = (a0[2] + x * ab[2]) - t[2]
    l0, l1, l2 = rtw3(R, w0, w1, w2)
    if cylinder:
        return _cylinder_gap(l0, l1, l2, size)
    return _box_gap(l0, l1, l2, size)


@kernel
def _capsule_solid(a0: Any, a1: Any, r: float, M: Any, size: Any, cylinder: bool) -> Any:
    """Capsule against a convex solid (module docstring): golden section on the segment."""
    R = np.ascontiguousarray(M[:3, :3])
    t = np.ascontiguousarray(M[:3, 3])
    ab = a1 - a0  # the same difference at every point: the iterates of the full form
    g = 0.5 * (np.sqrt(5.0) - 1.0)
    lo, hi = 0.0, 1.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1 = _gap(x1, a0, ab, R, t, size, cylinder)
    f2 = _gap(x2, a0, ab, R, t, size, cylinder)
    for _ in range(GOLDEN_ITERATIONS):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = _gap(x1, a0, ab, R, t, size, cylinder)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = _gap(x2, a0, ab, R, t, size, cylinder)
    best_s = 0.5 * (lo + hi)
    best_f = _gap(best_s, a0, ab, R, t, size, cylinder)
    for s in (0.0, 1.0):  # the minimum may sit on an end
        f = _gap(s, a0, ab, R, t, size, cylinder)
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
