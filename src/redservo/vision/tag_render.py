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

Each pixel is mapped through the plane's homography (with the camera's distortion) and
sampled ``SUPERSAMPLE x SUPERSAMPLE`` times: its coverage is the fraction of its samples on
the paper (paper layer) and on a black cell (ink layer), which places the tag's edges to a
few hundredths of a pixel. The tag is drawn only from its printed side (the camera on the
``+z`` side of the tag frame) and only when its paper is wholly in front of the camera.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.camera import MIN_DEPTH
from redservo.scene import Tag
from redservo.tag_families import TAG_FAMILIES
from redservo.vision.optics import Optics, require_cv2
from redservo.vision.shapes import Layer

__all__ = ["INK_LEVEL", "PAPER_LEVEL", "SUPERSAMPLE", "tag_bits", "tag_layers"]

PAPER_LEVEL = 220.0
"""Gray level of the tag's white cells and margin."""
INK_LEVEL = 20.0
"""Gray level of its black cells."""
SUPERSAMPLE = 4
"""Samples per pixel side for the coverage."""


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
    optics: Optics, Hinv: FloatArray, s: float, cells: NDArray[np.bool_] | None
) -> Callable[[slice, slice], FloatArray]:
    """Coverage of the paper (``cells`` None) or of the black cells, by supersampling."""
    n = SUPERSAMPLE
    off = (np.arange(n) + 0.5) / n

    def coverage(rows: slice, cols: slice) -> FloatArray:
        h, w = rows.stop - rows.start, cols.stop - cols.start
        u = (np.arange(cols.start, cols.stop)[:, None] + off[None, :]).ravel()
        v = (np.arange(rows.start, rows.stop)[:, None] + off[None, :]).ravel()
        uu, vv = np.meshgrid(u, v)
        xy = optics.to_normalized(np.stack([uu, vv], axis=-1))
        x, y = xy[..., 0], xy[..., 1]
        q0 = Hinv[0, 0] * x + Hinv[0, 1] * y + Hinv[0, 2]
        q1 = Hinv[1, 0] * x + Hinv[1, 1] * y + Hinv[1, 2]
        q2 = Hinv[2, 0] * x + Hinv[2, 1] * y + Hinv[2, 2]
        front = q2 > 0.0
        q2 = np.where(front, q2, 1.0)
        a, b = q0 / q2, q1 / q2  # tag-frame coordinates (m)
        if cells is None:
            m = 0.5 * s
            hit = front & (np.abs(a) < m) & (np.abs(b) < m)
        else:
            k = cells.shape[0]
            col = np.floor((0.5 * s - a) * (k / s)).astype(np.int64)
            row = np.floor((b + 0.5 * s) * (k / s)).astype(np.int64)
            inside = front & (col >= 0) & (col < k) & (row >= 0) & (row < k)
            hit = inside & cells[np.clip(row, 0, k - 1), np.clip(col, 0, k - 1)]
        out: FloatArray = hit.reshape(h, n, w, n).mean(axis=(1, 3))
        return out

    return coverage


def tag_layers(obj: Tag, cMo: FloatArray, optics: Optics) -> list[Layer]:
    """The paper and ink layers of ``obj`` at pose ``cMo`` (4x4), or none when not drawn."""
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
    Hinv = np.linalg.inv(H)
    depth = float(np.linalg.norm(t))
    rect = (r0, r1, c0, c1)
    return [
        Layer(obj.name, "tag", depth, PAPER_LEVEL, rect, _coverage(optics, Hinv, paper, None)),
        Layer(
            f"{obj.name}.ink",
            "tag",
            depth * (1.0 - 1e-9),
            INK_LEVEL,
            rect,
            _coverage(optics, Hinv, obj.size, cells),
        ),
    ]
