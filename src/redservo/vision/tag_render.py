"""What a fiducial tag looks like in the image: its paper and its black cells, as two layers.

A :class:`~redservo.scene.Tag` of side ``s`` with ``b`` bits per side is a grid of
``N = b + 2`` cells of side ``s/N`` (the one-cell black border included), printed on a white
square one cell wider on every side. The bit pattern is OpenCV's
(``cv2.aruco.generateImageMarker``), placed in the tag frame of :class:`~redservo.scene.Tag`
(ViSP's): the marker image's column axis runs along ``-x`` and its row axis along ``+y``, so
that OpenCV's corners (top-left, top-right, bottom-right, bottom-left of the marker image)
are the tag-frame corners 1, 0, 3, 2 (``size/2`` times ``(1, -1), (-1, -1), (-1, 1), (1, 1)``)
and AprilTag 3 finds the tag's corner ``k`` at the image of corner ``k``
(``tests/test_vision_tags.py`` checks it with the AprilTag 3 bindings when installed).

Each pixel centre is mapped through the plane's homography (after undistortion) to the
cell grid; the pixel blends its cell with its neighbours across the nearest grid lines with the
1-px ramp of the other shapes (:mod:`redservo.vision.shapes`), ``clip(0.5 + d, 0, 1)``, ``d`` the
distance to the line in pixels (first order): a straight edge is placed to about 0.01 px. The
tag is drawn only from its printed side (the camera on the ``+z`` side of the tag frame) and
only when its paper is wholly in front of the camera.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.camera import MIN_DEPTH
from redservo.scene import Tag
from redservo.vision.optics import Optics, require_cv2
from redservo.vision.tag_families import TAG_FAMILIES

__all__ = ["INK_LEVEL", "PAPER_LEVEL", "LayerParts", "tag_bits", "tag_layers"]

LayerParts = tuple[str, str, float, float, tuple[int, int, int, int], Any]
"""``(name, kind, depth, level, rect, coverage)``: the fields of a ``shapes.Layer``."""

PAPER_LEVEL = 220.0
"""Gray level of the tag's white cells and margin."""
INK_LEVEL = 20.0
"""Gray level of its black cells."""


@lru_cache(maxsize=64)
def tag_bits(family: str, tag_id: int) -> NDArray[np.bool_]:
    """(N, N) True where the cell is black (OpenCV's marker image, row 0 at the top)."""
    cv2 = require_cv2()
    const, bits, _ = TAG_FAMILIES[family]
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, const))
    img = cv2.aruco.generateImageMarker(d, int(tag_id), bits + 2, borderBits=1)
    out: NDArray[np.bool_] = np.asarray(img) < 128
    out.setflags(write=False)
    return out


def _coverage(
    optics: Optics, M: FloatArray, pattern: NDArray[np.float64]
) -> Callable[[slice, slice], FloatArray]:
    """Coverage of the cells of ``pattern`` (1 = covered), with a zero border around it.

    ``M`` (3x3) maps normalized ``(x, y, 1)`` to homogeneous cell coordinates
    ``(col, row, 1)`` (column 0 on the pattern's left edge). Each pixel blends its own cell
    and its neighbours across the nearest column and row lines with the renderer's 1-px ramp
    ``clip(0.5 + d, 0, 1)``, ``d`` the distance to that line in pixels (first order).
    """
    padded = np.pad(pattern, 1)
    last = padded.shape[0] - 1
    sx, sy = 1.0 / optics.camera.px, 1.0 / optics.camera.py

    def coverage(rows: slice, cols: slice) -> FloatArray:
        x, y = optics.grid(rows, cols)
        C = M[0, 0] * x + M[0, 1] * y + M[0, 2]
        R = M[1, 0] * x + M[1, 1] * y + M[1, 2]
        W = M[2, 0] * x + M[2, 1] * y + M[2, 2]
        front = W > 0.0
        W = np.where(front, W, 1.0)
        col, row = C / W, R / W
        W2 = W * W
        gc = np.hypot((M[0, 0] * W - C * M[2, 0]) * sx, (M[0, 1] * W - C * M[2, 1]) * sy) / W2
        gr = np.hypot((M[1, 0] * W - R * M[2, 0]) * sx, (M[1, 1] * W - R * M[2, 1]) * sy) / W2
        out = np.zeros(col.shape)
        for value, grad, store in ((col, gc, 0), (row, gr, 1)):
            i = np.floor(value)
            f = value - i
            near = np.where(f < 0.5, -1.0, 1.0)  # the neighbour across the nearest line
            dist = np.where(f < 0.5, f, 1.0 - f) / np.maximum(grad, 1e-12)
            own = np.clip(0.5 + dist, 0.0, 1.0)
            idx = np.clip(i + 1.0, 0, last).astype(np.intp)  # +1: the zero border
            nb = np.clip(i + 1.0 + near, 0, last).astype(np.intp)
            if store == 0:
                c_own, c_nb, wc = idx, nb, own
            else:
                r_own, r_nb, wr = idx, nb, own
        out = wr * (wc * padded[r_own, c_own] + (1.0 - wc) * padded[r_own, c_nb]) + (1.0 - wr) * (
            wc * padded[r_nb, c_own] + (1.0 - wc) * padded[r_nb, c_nb]
        )
        return np.where(front, out, 0.0)

    return coverage


def tag_layers(obj: Tag, cMo: FloatArray, optics: Optics) -> list[LayerParts]:
    """The paper and ink layers of ``obj`` at pose ``cMo`` (4x4), or none when not drawn, as the
    arguments of :class:`redservo.vision.shapes.Layer` (which builds them: no import cycle)."""
    R, t = cMo[:3, :3], cMo[:3, 3]
    if float(R[:, 2] @ t) >= 0.0:
        return []  # seen from behind
    cells = tag_bits(obj.family, obj.tag_id)
    k = cells.shape[0]
    paper = obj.size * (k + 2) / k
    corners = 0.5 * paper * np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    P = corners @ R[:, :2].T + t
    if np.any(P[:, 2] <= MIN_DEPTH):
        return []
    uv = optics.to_pixel(P[:, :2] / P[:, 2:3])
    if not np.all(np.isfinite(uv)):
        return []
    margin = 2.0 + (0.05 * float(np.ptp(uv, axis=0).max()) if optics.distorted else 0.0)
    lo, hi = uv.min(axis=0) - margin, uv.max(axis=0) + margin
    hgt, wid = optics.shape
    r0, r1 = max(int(np.floor(lo[1])), 0), min(int(np.ceil(hi[1])), hgt)
    c0, c1 = max(int(np.floor(lo[0])), 0), min(int(np.ceil(hi[0])), wid)
    if r0 >= r1 or c0 >= c1:
        return []
    H = np.column_stack([R[:, 0], R[:, 1], t])
    Hinv = np.linalg.inv(H)  # normalized (x, y, 1) to the tag plane (a, b, 1), up to scale

    def to_cells(side: float, n: int) -> FloatArray:
        """Tag plane to the cells of an n x n grid of ``side`` (the marker image's axes:
        columns along -x, rows along +y, corner (0, 0) at (side/2, -side/2))."""
        A = np.array([[-n / side, 0.0, 0.5 * n], [0.0, n / side, 0.5 * n], [0.0, 0.0, 1.0]])
        return np.asarray(A @ Hinv, dtype=float)

    depth = float(np.linalg.norm(t))
    rect = (r0, r1, c0, c1)
    white = np.ones((1, 1))
    ink = cells.astype(float)
    paper_cov = _coverage(optics, to_cells(paper, 1), white)
    ink_cov = _coverage(optics, to_cells(obj.size, k), ink)
    return [
        (obj.name, "tag", depth, PAPER_LEVEL, rect, paper_cov),
        (f"{obj.name}.ink", "tag", depth * (1.0 - 1e-9), INK_LEVEL, rect, ink_cov),
    ]
