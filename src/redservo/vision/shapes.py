"""What each scene object looks like in the image: anti-aliased coverage layers.

A :class:`Layer` is one object's footprint: its gray level, a depth for the
painter's order, the pixel rectangle it can touch (clipped to the image), and a
function returning its *coverage* ``α`` in [0, 1] on any sub-rectangle. The
renderer composites layers far to near, ``I ← (1 - α) I + α level``.

Geometry (exact in normalized coordinates, pixel ray ``p = (x, y, 1)``):

* a point of a :class:`~redservo.scene.PointSet` is a disc of constant radius
  ``dot_radius_px`` centred on its (distorted) projection — a disc of constant
  pixel size keeps its centroid on the projected point at any pose; a point at
  or behind the camera plane (``Z <= MIN_DEPTH``) is not drawn;
* a sphere (centre ``X0``, radius ``r``) covers the rays with
  ``(X0·p)² >= (|X0|² - r²)|p|²`` and ``X0·p > 0`` (the viewing cone; exact for a
  sphere partly behind the camera, where the image is unbounded); the whole
  image when the camera is inside it;
* a cylinder (unit axis ``a``, axis point ``X0``, radius ``R``, ``w = X0 x a``)
  covers the rays with ``((p x a)·w)² >= (|w|² - R²)|p x a|²`` and
  ``(p x a)·w > 0``: the band between its limbs, cut at the vanishing point;
* a :class:`~redservo.scene.Line` is a stripe ``line_width_px`` wide along its
  image line, on the half whose 3-D points are in front of the camera.

Anti-aliasing: the coverage is a 1-pixel linear ramp across the boundary,
``α = clip(0.5 + f/|∇f|, 0, 1)`` with ``f/|∇f|`` the signed distance to the
boundary in pixels (first order), so that edges and centroids are located to a
small fraction of a pixel.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from redservo._validation import FloatArray
from redservo.camera import MIN_DEPTH
from redservo.features import object_adapter
from redservo.features.sphere import sphere_ellipse
from redservo.scene import Cylinder, Line, PointSet, Scene, Sphere, Tag
from redservo.vision.optics import Optics

__all__ = ["Layer", "Levels", "disc_coverage", "scene_layers"]

Rect = tuple[int, int, int, int]
"""Pixel rectangle ``(row0, row1, col0, col1)``, half-open."""


@dataclass(frozen=True)
class Levels:
    """Gray levels (0-255) and sizes the objects are drawn with."""

    point: float = 240.0
    sphere: float = 160.0
    cylinder: float = 110.0
    line: float = 160.0
    dot_radius_px: float = 4.0
    line_width_px: float = 3.0


@dataclass(frozen=True)
class Layer:
    """One object's footprint; ``coverage(rows, cols)`` returns α (len(rows), len(cols))."""

    name: str
    kind: str
    depth: float
    level: float
    rect: Rect
    coverage: Callable[[slice, slice], FloatArray]
    disc: tuple[float, float, float] | None = None
    """A dot's disc ``(u, v, radius)`` (pixels), whose coverage is :func:`disc_coverage`."""


def _clip_rect(r0: float, r1: float, c0: float, c1: float, shape: tuple[int, int]) -> Rect | None:
    h, w = shape
    lo_r, hi_r = max(int(np.floor(r0)), 0), min(int(np.ceil(r1)), h)
    lo_c, hi_c = max(int(np.floor(c0)), 0), min(int(np.ceil(c1)), w)
    if lo_r >= hi_r or lo_c >= hi_c:
        return None
    return lo_r, hi_r, lo_c, hi_c


def disc_coverage(
    rows: slice, cols: slice, cu: FloatArray, cv: FloatArray, radius: float
) -> FloatArray:
    """Coverage (n, len(rows), len(cols)) of the n discs of centres ``(cu, cv)`` (n,) and
    ``radius`` (pixels): ``clip(radius + 0.5 - d, 0, 1)``, ``d`` from the pixel centres."""
    du = (np.arange(cols.start, cols.stop) + 0.5)[None, :] - cu[:, None]
    dv = (np.arange(rows.start, rows.stop) + 0.5)[None, :] - cv[:, None]
    d = np.sqrt(du[:, None, :] ** 2 + dv[:, :, None] ** 2)
    return np.clip(radius + 0.5 - d, 0.0, 1.0)


def _disc(optics: Optics, uv: FloatArray, radius: float) -> Callable[[slice, slice], FloatArray]:
    cu, cv = np.array([uv[0]], dtype=float), np.array([uv[1]], dtype=float)

    def coverage(rows: slice, cols: slice) -> FloatArray:
        return disc_coverage(rows, cols, cu, cv, radius)[0]

    return coverage


def _cone(optics: Optics, Q: FloatArray, g: FloatArray) -> Callable[[slice, slice], FloatArray]:
    """Coverage of ``{p : pᵀ Q p >= 0, g·p > 0}`` (Q symmetric 3x3)."""
    sx, sy = 1.0 / optics.camera.px, 1.0 / optics.camera.py

    def coverage(rows: slice, cols: slice) -> FloatArray:
        x, y = optics.grid(rows, cols)
        qx = Q[0, 0] * x + Q[0, 1] * y + Q[0, 2]
        qy = Q[1, 0] * x + Q[1, 1] * y + Q[1, 2]
        qz = Q[2, 0] * x + Q[2, 1] * y + Q[2, 2]
        f = x * qx + y * qy + qz
        grad = 2.0 * np.hypot(qx * sx, qy * sy)
        dist = f / np.maximum(grad, 1e-300)
        alpha = np.clip(0.5 + dist, 0.0, 1.0)
        front = g[0] * x + g[1] * y + g[2] > 0.0
        return np.where(front, alpha, 0.0)

    return coverage


def _full(value: float) -> Callable[[slice, slice], FloatArray]:
    def coverage(rows: slice, cols: slice) -> FloatArray:
        return np.full((rows.stop - rows.start, cols.stop - cols.start), value)

    return coverage


def _stripe(
    optics: Optics, P0: FloatArray, u: FloatArray, width: float
) -> Callable[[slice, slice], FloatArray]:
    n = np.cross(P0, u)
    sx, sy = 1.0 / optics.camera.px, 1.0 / optics.camera.py
    norm = float(np.hypot(n[0] * sx, n[1] * sy))

    def coverage(rows: slice, cols: slice) -> FloatArray:
        x, y = optics.grid(rows, cols)
        dist = np.abs(n[0] * x + n[1] * y + n[2]) / max(norm, 1e-300)
        alpha = np.clip(0.5 * width + 0.5 - dist, 0.0, 1.0)
        # Depth factor along the ray: λ p on the line, λ = n·(p x u)/|p x u|².
        cx = y * u[2] - u[1]
        cy = u[0] - x * u[2]
        cz = x * u[1] - y * u[0]
        lam = (n[0] * cx + n[1] * cy + n[2] * cz) / np.maximum(cx * cx + cy * cy + cz * cz, 1e-300)
        return np.where(lam > MIN_DEPTH, alpha, 0.0)

    return coverage


def _ellipse_rect(optics: Optics, radius: float, X0: FloatArray) -> Rect | None:
    """Pixel rectangle of a sphere entirely in front of the camera (3 px margin)."""
    img = sphere_ellipse(radius, X0)
    M = 4.0 * np.array([[img.n20, img.n11], [img.n11, img.n02]])
    evals, evecs = np.linalg.eigh(M)
    t = np.linspace(0.0, 2.0 * np.pi, 73)
    axes = evecs * np.sqrt(np.maximum(evals, 0.0))
    pts = np.array([img.xc, img.yc]) + (axes @ np.stack([np.cos(t), np.sin(t)])).T
    uv = optics.to_pixel(pts)
    if optics.distorted:  # the boundary bulges between samples
        margin = 3.0 + 0.05 * float(np.ptp(uv, axis=0).max())
    else:
        margin = 3.0
    lo, hi = uv.min(axis=0) - margin, uv.max(axis=0) + margin
    return _clip_rect(lo[1], hi[1], lo[0], hi[0], optics.shape)


def _point_layers(obj: PointSet, cMo: FloatArray, optics: Optics, lv: Levels) -> list[Layer]:
    P = obj.points @ cMo[:3, :3].T + cMo[:3, 3]
    front = P[:, 2] > MIN_DEPTH
    UV = optics.to_pixel(P[:, :2] / np.where(front, P[:, 2], 1.0)[:, None])  # all dots at once
    out = []
    R = lv.dot_radius_px
    for k in np.flatnonzero(front & np.isfinite(UV).all(axis=1)):
        uv = UV[k]
        rect = _clip_rect(uv[1] - R - 2, uv[1] + R + 2, uv[0] - R - 2, uv[0] + R + 2, optics.shape)
        if rect is not None:
            cov, disc = _disc(optics, uv, R), (float(uv[0]), float(uv[1]), R)
            out.append(
                Layer(f"{obj.name}[{k}]", "point", float(P[k, 2]), lv.point, rect, cov, disc)
            )
    return out


def _sphere_layer(obj: Sphere, cMo: FloatArray, optics: Optics, lv: Levels) -> Layer | None:
    X0 = cMo[:3, :3] @ obj.center + cMo[:3, 3]
    r = obj.radius
    k = float(X0 @ X0) - r * r
    h, w = optics.shape
    full: Rect = (0, h, 0, w)
    depth = float(np.linalg.norm(X0))
    if k <= 0.0:  # camera inside the sphere: it fills the view
        return Layer(obj.name, "sphere", 0.0, lv.sphere, full, _full(1.0))
    if X0[2] - r > MIN_DEPTH:
        rect = _ellipse_rect(optics, r, X0)
        if rect is None:
            return None
    elif X0[2] + r <= MIN_DEPTH:
        return None  # entirely behind the camera plane
    else:
        rect = full
    Q = np.outer(X0, X0) - k * np.eye(3)
    return Layer(obj.name, "sphere", depth, lv.sphere, rect, _cone(optics, Q, X0))


def _cylinder_layer(obj: Cylinder, cMo: FloatArray, optics: Optics, lv: Levels) -> Layer:
    a = cMo[:3, :3] @ obj.axis
    X0 = cMo[:3, :3] @ obj.point + cMo[:3, 3]
    wv = np.cross(X0, a)
    c = float(wv @ wv) - obj.radius**2
    h, w = optics.shape
    if c <= 0.0:  # camera inside the cylinder
        return Layer(obj.name, "cylinder", 0.0, lv.cylinder, (0, h, 0, w), _full(1.0))
    g = np.cross(a, wv)
    Q = np.outer(g, g) - c * (np.eye(3) - np.outer(a, a))
    depth = float(np.linalg.norm(wv))
    return Layer(obj.name, "cylinder", depth, lv.cylinder, (0, h, 0, w), _cone(optics, Q, g))


def _line_layer(obj: Line, cMo: FloatArray, optics: Optics, lv: Levels) -> Layer | None:
    u = cMo[:3, :3] @ obj.direction
    P0 = cMo[:3, :3] @ obj.point + cMo[:3, 3]
    perp = P0 - (u @ P0) * u
    if float(perp @ perp) <= MIN_DEPTH**2:
        return None  # through the optical centre: images to a point
    h, w = optics.shape
    cov = _stripe(optics, P0, u, lv.line_width_px)
    return Layer(obj.name, "line", float(np.linalg.norm(perp)), lv.line, (0, h, 0, w), cov)


def scene_layers(
    scene: Scene, bMc: FloatArray, t: float, optics: Optics, levels: Levels
) -> list[Layer]:
    """Every visible footprint of the scene's objects, sorted far to near.

    Objects wholly outside the image or behind the camera give no layer; a
    partly visible object's rectangle is clipped to the image.
    """
    layers: list[Layer] = []
    for name in scene.names:
        obj = scene.object(name)
        cMo = scene.cMo(name, bMc, t)
        if isinstance(obj, Tag):
            from redservo.vision.tag_render import tag_layers

            layers.extend(Layer(*parts) for parts in tag_layers(obj, cMo, optics))
            continue
        render = object_adapter(obj, "render")  # its feature kind's (redservo.features.kinds)
        drawn = None if render is None else render(obj, cMo, optics, levels)
        layers.extend(drawn if isinstance(drawn, list) else [] if drawn is None else [drawn])
    layers.sort(key=lambda ly: -ly.depth)
    return layers
