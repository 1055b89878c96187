"""The image motion of the dots predicted from the camera's own motion (issue 28, item 3).

Between two frames the robot knows how its camera moved (its joint encoders, or the
commands it sent): ``cMc' = bMc⁻¹ · bMc'``. A dot seen at ``(x, y)`` (normalized) with
inverse depth ``ρ = 1/Z`` (the sensor's current depth parameters: ``(1/Z,)`` of a point
term, ``1/Z = A x + B y + C`` of a moment term) is the point ``P = (x, y, 1) / ρ`` of the
camera frame; in the new frame it is ``P' = (cMc')⁻¹ P``, imaged at ``(x', y') = P'_xy /
P'_z``. The predicted shift ``uv' - uv`` (pixels, through the lens distortion of
:class:`~redservo.vision.optics.Optics`) is what
:meth:`~redservo.vision.tracking.ImageDotTracker.update` centres each dot's search window
on, instead of its constant-velocity guess: a fast camera motion no longer throws the dots
out of the tracker's gate. It is exact for a static target and the true depth, and to
first order the interaction matrix ``L_x(x, y, Z) · v dt``; a dot without a depth estimate
or behind the camera gets NaN (no prediction: the tracker's own).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from redservo._validation import FloatArray
from redservo.camera import MIN_DEPTH
from redservo.kernels import compiled, lazy
from redservo.vision.optics import Optics
from redservo.vision.terms import TermState

if TYPE_CHECKING:  # the kernel module, typed; imported on first use at run time
    from redservo.kernels import dot_shift as _KS
else:
    _KS = lazy("dot_shift")  # the command line starts without numba

__all__ = ["camera_shift", "dot_inv_depths", "normalized_dots", "predicted_shift"]


def dot_inv_depths(terms: Sequence[TermState], n_dots: int, xy: FloatArray) -> FloatArray:
    """Inverse depth (1/m) of each of ``n_dots`` dots at normalized ``xy`` (N, 2) from the
    terms' last depth parameters; NaN where no term gives one."""
    rho = np.full(n_dots, np.nan)
    for st in terms:
        if st.inv_depth is None or not st.dots.size:
            continue
        p = np.asarray(st.inv_depth, dtype=float).ravel()
        if st.kind == "point" and p.size == 1:
            rho[st.dots] = p[0]
        elif st.kind == "moments" and p.size == 3:
            rho[st.dots] = p[0] * xy[st.dots, 0] + p[1] * xy[st.dots, 1] + p[2]
    return rho


def predicted_shift(
    optics: Optics,
    uv: FloatArray,
    inv_depth: FloatArray,
    bMc_prev: FloatArray,
    bMc: FloatArray,
    xy: FloatArray | None = None,
) -> FloatArray:
    """Image motion (N, 2) in pixels of the dots at ``uv`` (N, 2, pixels) with inverse depths
    ``inv_depth`` (N,) (1/m) when the camera moves from ``bMc_prev`` to ``bMc`` (4x4, m);
    ``xy``: ``optics.to_normalized(uv)`` when the caller has it (row by row the same)."""
    rho = np.asarray(inv_depth, dtype=float)
    ok = np.isfinite(rho) & (rho > 0.0) & np.isfinite(uv).all(axis=1)
    every = bool(ok.all())  # the common frame: no row to pick
    if not every and not ok.any():
        return np.full(uv.shape, np.nan)
    uv_ok = uv if every else uv[ok]
    if xy is None:
        xy = optics.to_normalized(uv_ok)
    elif not every:
        xy = xy[ok]
    P = np.column_stack([xy, np.ones(len(xy))]) / (rho if every else rho[ok])[:, None]
    cMc = np.linalg.solve(bMc, bMc_prev)  # old camera frame -> new camera frame
    Q = P @ cMc[:3, :3].T + cMc[:3, 3]
    front = Q[:, 2] > MIN_DEPTH
    if every and front.all():
        return np.asarray(optics.to_pixel(Q[:, :2] / Q[:, 2:]) - uv, dtype=float)
    out = np.full(uv.shape, np.nan)
    moved = np.full((len(Q), 2), np.nan)
    moved[front] = optics.to_pixel(Q[front, :2] / Q[front, 2:]) - uv_ok[front]
    out[ok] = moved
    return out


def camera_shift(
    terms: Sequence[TermState],
    optics: Optics,
    uv: FloatArray,
    bMc_prev: FloatArray | None,
    bMc: FloatArray,
) -> FloatArray | None:
    """The predicted shift (N, 2) pixels of the dots at ``uv`` (N, 2) pixels from the terms'
    depth parameters and the camera's motion since ``bMc_prev`` (None: no last frame)."""
    if bMc_prev is None:
        return None
    if optics.distorted or not compiled():
        xy = optics.to_normalized(uv)
        rho = dot_inv_depths(terms, len(uv), xy)
        return predicted_shift(optics, uv, rho, bMc_prev, bMc, xy)
    # without distortion: the same numbers in two compiled calls (kernels/dot_shift.py)
    k = _params(optics)
    pix = np.ascontiguousarray(uv, dtype=float)
    xy = _KS.normalized(pix, k)
    rho = dot_inv_depths(terms, len(pix), xy)
    if not (rho > 0.0).any():  # no dot to move: no camera motion needed
        return np.full(pix.shape, np.nan)
    cMc = np.ascontiguousarray(np.linalg.solve(bMc, bMc_prev))
    out: FloatArray = _KS.shift(pix, xy, rho, cMc, k)
    return out


def _params(optics: Optics) -> FloatArray:
    """``(px, py, u0, v0, MIN_DEPTH)`` of ``optics``' camera (pixels, m), for
    :mod:`redservo.kernels.dot_shift`."""
    c = optics.camera
    return np.array([c.px, c.py, c.u0, c.v0, MIN_DEPTH])


def normalized_dots(optics: Optics, uv: FloatArray) -> FloatArray:
    """``optics.to_normalized(uv)`` of the dots' pixels ``uv`` (N, 2): the same numbers, in
    one compiled call through a camera without distortion
    (:func:`redservo.kernels.dot_shift.normalized`)."""
    if optics.distorted or not compiled():
        return optics.to_normalized(uv)
    out: FloatArray = _KS.normalized(np.ascontiguousarray(uv, dtype=float), _params(optics))
    return out
