"""Sub-pixel corners of a tag from its four edges (after OpenCV finds the quad).

OpenCV's ``CORNER_REFINE_SUBPIX`` places the corners of a tag rendered with pixel noise
σ = 2 gray levels at about 0.29 px RMS from the truth; its ``CORNER_REFINE_APRILTAG`` took
about 110 ms a frame with a bias of 0.45 px (docs/decisions.md). Like AprilTag 3's
``refine_edges``, :func:`refine_quad` instead locates each outer edge of the black border:
at points spread along the edge it finds where the gray level steps between the two
sides (from the area under the profile across the edge, sampled every 0.25 px over
± 0.4 cell: the position of a sharp step of the same area), fits a line to them (weighted total least squares) and intersects neighbouring
lines. Coordinates in OpenCV's pixel convention (centres on the integers).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.vision.optics import require_cv2

__all__ = ["refine_quad"]

_STEP_PX = 0.25

_Lens = tuple[FloatArray, FloatArray]
"""OpenCV's camera matrix (3, 3) and distortion vector (5,)."""


def _edge_line(
    img: NDArray[np.float32], P: FloatArray, Q: FloatArray, reach: float, lens: _Lens | None
) -> tuple[FloatArray, FloatArray] | None:
    """``(point, unit normal)`` of the edge line near segment ``PQ``, or None."""
    cv2 = require_cv2()
    d = Q - P
    length = float(np.hypot(*d))
    if length < 4.0:
        return None
    d = d / length
    n = np.array([-d[1], d[0]])
    m = int(np.clip(length / 2.0, 6, 64))
    t = np.linspace(0.15, 0.85, m) * length
    s = np.arange(-reach, reach + 1e-9, _STEP_PX)
    pts = P + t[:, None] * d  # (m, 2)
    grid = pts[:, None, :] + s[None, :, None] * n  # (m, k, 2)
    prof = cv2.remap(
        img,
        grid[..., 0].astype(np.float32),
        grid[..., 1].astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
    prof = prof.astype(float)
    # The step's position from its area: with the levels a (start) and b (end) read on the
    # profile's ends, the edge is where a step of the same area would be (exact for
    # area-sampled pixels and any symmetric blur; a gradient centroid is not).
    a = prof[:, :3].mean(axis=1)
    b = prof[:, -3:].mean(axis=1)
    contrast = a - b
    ok = np.abs(contrast) > 10.0
    if np.count_nonzero(ok) < 3:
        return None
    frac = (prof[ok] - b[ok, None]) / contrast[ok, None]
    inner = 0.5 * (frac[:, 1:] + frac[:, :-1])  # trapezoids
    off = s[0] + inner.sum(axis=1) * _STEP_PX
    w = np.abs(contrast[ok])
    X = pts[ok] + off[:, None] * n
    if lens is not None:  # edges are straight in the undistorted image
        X = cv2.undistortPoints(X.reshape(-1, 1, 2), lens[0], lens[1], P=lens[0]).reshape(-1, 2)
    wt = w / w.sum()
    c = wt @ X
    C = (X - c).T @ ((X - c) * wt[:, None])
    _, evecs = np.linalg.eigh(C)
    return c, evecs[:, 0]  # the normal: the direction of least spread


def refine_quad(
    gray: NDArray[np.uint8], corners: FloatArray, cells: int, lens: _Lens | None = None
) -> FloatArray:
    """Refined corners (4, 2) of a quad (corners in order around it, OpenCV's convention);
    ``cells`` is the tag's width in cells (the search reaches 0.4 cell). With ``lens``
    (OpenCV's camera matrix and distortion vector) the lines are fitted to the undistorted
    edge points and the corners distorted back. A corner whose edges cannot be fitted keeps
    its input value."""
    side = float(np.mean(np.hypot(*(np.roll(corners, -1, axis=0) - corners).T)))
    reach = float(np.clip(0.4 * side / cells, 0.75, 3.0))
    img = gray.astype(np.float32)
    lines = [_edge_line(img, corners[k], corners[(k + 1) % 4], reach, lens) for k in range(4)]
    out = corners.copy()
    cv2 = require_cv2()
    for k in range(4):
        a, b = lines[k - 1], lines[k]  # the edges ending and starting at corner k
        if a is None or b is None:
            continue
        A = np.array([a[1], b[1]])
        if abs(float(np.linalg.det(A))) < 1e-6:
            continue
        p = np.linalg.solve(A, np.array([a[1] @ a[0], b[1] @ b[0]]))
        if lens is not None:
            K, dist = lens
            xy = np.array([[(p[0] - K[0, 2]) / K[0, 0], (p[1] - K[1, 2]) / K[1, 1], 1.0]])
            p = cv2.projectPoints(xy, np.zeros(3), np.zeros(3), K, dist)[0].reshape(2)
        if float(np.hypot(*(p - corners[k]))) <= 2.0 * reach:
            out[k] = p
    return out
