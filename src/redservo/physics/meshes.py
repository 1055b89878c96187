"""Finely tessellated meshes of a sphere and a cylinder, for outlines true to a pixel's tenth.

MuJoCo draws its built-in sphere and cylinder as polygons of ``visual/quality numslices``
(default 28) sides: the outline of a 30-pixel sphere is then up to 0.19 px inside the true
one (``R (1 − cos(π/28))``), measured -0.16 px on its radius; raising ``numslices`` for the
whole model would refine the arm's every capsule too and costs 2-4 times the frame. These
meshes refine only the observed objects: ``SLICES`` sides around (and ``SLICES / 2``
stacks), their vertices pushed out by ``2 / (1 + cos(π / SLICES))`` so that the polygon's
outline is as much outside the true one at its vertices as inside it between them (a
residual of ``± R (1 − cos(π / SLICES)) / 2``, 0.004 px on a 30-pixel radius).

Each mesh is closed (the cylinder has its two caps), so that MuJoCo can compute its volume
and inertia when the object is a carried body. Vertices are in the object's frame (m).
"""

from __future__ import annotations

import numpy as np

from redservo._validation import FloatArray

__all__ = ["SLICES", "cylinder_mesh", "sphere_mesh"]

SLICES = 96
"""Sides of the meshes' polygons around their axis."""


def _inflate(n: int) -> float:
    """Radius factor of an ``n``-gon whose outline straddles the circle it approximates."""
    return 2.0 / (1.0 + float(np.cos(np.pi / n)))


def _xml(name: str, vertices: FloatArray, faces: np.ndarray) -> str:
    v = " ".join(f"{x:.7g}" for x in vertices.ravel())
    f = " ".join(str(int(i)) for i in faces.ravel())
    return f'<mesh name="{name}" vertex="{v}" face="{f}"/>'


def sphere_mesh(name: str, radius: float, center: FloatArray, slices: int = SLICES) -> str:
    """``<mesh>`` asset of a sphere (m, object frame) with ``slices`` sides, ``slices/2`` stacks."""
    stacks = slices // 2
    r = radius * _inflate(slices)
    lat = np.pi * np.arange(1, stacks) / stacks  # polar angles of the rings (rad)
    lon = 2.0 * np.pi * np.arange(slices) / slices
    ring = np.stack(
        [
            np.outer(np.sin(lat), np.cos(lon)),
            np.outer(np.sin(lat), np.sin(lon)),
            np.outer(np.cos(lat), np.ones(slices)),
        ],
        axis=-1,
    ).reshape(-1, 3)
    verts = np.vstack([[0.0, 0.0, 1.0], ring, [0.0, 0.0, -1.0]]) * r + center
    south = verts.shape[0] - 1
    j = np.arange(slices)
    jn = (j + 1) % slices
    faces = [np.stack([np.zeros(slices, int), 1 + j, 1 + jn], axis=1)]  # north cap
    for k in range(stacks - 2):
        a, b = 1 + k * slices, 1 + (k + 1) * slices
        faces.append(np.stack([a + j, b + j, b + jn], axis=1))
        faces.append(np.stack([a + j, b + jn, a + jn], axis=1))
    last = 1 + (stacks - 2) * slices
    faces.append(np.stack([np.full(slices, south), last + jn, last + j], axis=1))  # south cap
    return _xml(name, verts, np.vstack(faces))


def cylinder_mesh(
    name: str, radius: float, start: FloatArray, end: FloatArray, slices: int = SLICES
) -> str:
    """``<mesh>`` asset of the closed cylinder of ``radius`` from ``start`` to ``end`` (m)."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    axis = (end - start) / np.linalg.norm(end - start)
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    lon = 2.0 * np.pi * np.arange(slices) / slices
    circle = radius * _inflate(slices) * (np.outer(np.cos(lon), u) + np.outer(np.sin(lon), w))
    verts = np.vstack([start, end, start + circle, end + circle])
    j = np.arange(slices)
    jn = (j + 1) % slices
    lo, hi = 2 + j, 2 + slices + j
    lon_, hin = 2 + jn, 2 + slices + jn
    faces = np.vstack(
        [
            np.stack([np.zeros(slices, int), lon_, lo], axis=1),  # start cap
            np.stack([np.ones(slices, int), hi, hin], axis=1),  # end cap
            np.stack([lo, lon_, hin], axis=1),
            np.stack([lo, hin, hi], axis=1),
        ]
    )
    return _xml(name, verts, faces)
