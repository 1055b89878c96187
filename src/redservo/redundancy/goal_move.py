"""The joint move of ``qp-goal`` to its goal ``q*`` with the task relaxed, the target kept in
the image (:mod:`redservo.redundancy.qp_goal`, "Switching rule").

One quadratic program per period (daqp, as ``qp``'s distance rows)::

    min  ‖J_g q̇ + λ e_g‖² + w ‖q̇ − q̇_2‖²,   q̇_2 = −k_g (q − q*),   w = weight · σ_max(J_g)²
    s.t. q̇_min ≤ q̇ ≤ q̇_max                                        (``qp``'s bounds)
         max(−v, ξ (u_min − u_i)/dt) ≤ u̇_i = S_i q̇ ≤ min(v, ξ (u_max − u_i)/dt)
                                                                  (each image coordinate)
         ḋ_ij = n_ijᵀ (S_i − S_j) q̇ ≥ −ξ (d_ij − d_min)/dt          (each pair of points)

``(J_g, e_g)``: the centroid of the model's image points and its error to their centroid at
``q*`` (2 rows; it holds the target in the middle of the image while the joints move, and
is met at ``q*``); the rows bound each point coordinate's motion per period (``v dt`` =
:data:`STEP_PX`) and damp it near the image border less :data:`MARGIN_PX` (ξ = :data:`XI` of
the gap closed per period at most); the pair rows keep every two points :data:`PAIR_PX`
apart (``d_ij`` their distance, ``n_ij`` its direction): two rendered dots closer than about
two radii merge and the tracker loses one (mc05-joint-limits sample 13 through the camera:
two dots 5 px apart in a move, ``feature_lost``). Units: rad or
m, rad/s or m/s, normalized image coordinates, pixels for the margins.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.redundancy.bls import daqp_once
from redservo.redundancy.predictive_model import horizon

__all__ = [
    "MARGIN_PX",
    "XI",
    "ImageRows",
    "centroid_rows",
    "image_rows",
    "kept_in_image",
    "pair_rows",
    "solve_move",
]

MARGIN_PX = 20.0
"""The image points stay this far (px) inside the image during the move."""
STEP_PX = 10.0
"""The image points move at most this far (px) per period during the move."""
RETURN = 0.5
"""A point past the border line less the margin returns by this fraction of the step per
period (the linear model's drift at a fast turn took one across it)."""
HALVINGS = 6
"""Halvings of the move's command at most to keep the nonlinear prediction in the image."""
XI = 0.2
"""Fraction of the gap to the bound a point coordinate may close in one period."""
PAIR_PX = 16.0
"""Two image points stay this far apart (px) during the move: four radii of a rendered dot
(``sensor.dot_radius_px`` = 4 px by default); the dots of mc05-joint-limits sample 13 were
tracked at 12-14 px and lost at 5 px."""


def _pairs(p: int) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """The index pairs ``i < j`` of ``p`` points."""
    i, j = np.triu_indices(p, 1)
    return i, j


class ImageRows(NamedTuple):
    """The model's image points at ``q`` and the centroid rows toward ``q*``."""

    s: FloatArray
    """(2p,) the points (x, y pairs), normalized."""
    S: FloatArray
    """(2p, n) their Jacobian."""
    Jg: FloatArray
    """(2, n) the centroid's Jacobian."""
    eg: FloatArray
    """(2,) the centroid's error to the goal's centroid."""


def centroid_rows(model: object, q: FloatArray, goal: FloatArray) -> ImageRows | None:
    """The model's image points at ``q`` and the centroid's rows toward ``goal`` (module
    docstring), or None (a point at or behind the camera, a model without image points)."""
    hz = horizon(1, 1)
    n = q.shape[0]
    now = model.predict(q, np.zeros((1, n)), hz, 0.0)  # type: ignore[attr-defined]
    end = model.predict(goal, np.zeros((1, n)), hz, 0.0)  # type: ignore[attr-defined]
    if now is None or end is None or now.s is None or now.S is None or end.s is None:
        return None
    s, S = now.s[0], now.S[0]
    Jg = np.ascontiguousarray(S.reshape(-1, 2, n).mean(axis=0))
    eg = s.reshape(-1, 2).mean(axis=0) - end.s[0].reshape(-1, 2).mean(axis=0)
    if not (np.all(np.isfinite(S)) and np.all(np.isfinite(s)) and np.all(np.isfinite(eg))):
        return None
    return ImageRows(s, S, Jg, np.ascontiguousarray(eg))


def image_rows(
    rows: ImageRows, camera: Camera, dt: float, back: float = RETURN
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(G, bl, bu)``: ``bl ≤ G q̇ ≤ bu``, one row per point coordinate (module docstring):
    at most :data:`STEP_PX` per period, and at most :data:`XI` of the gap to the image border
    less :data:`MARGIN_PX` per period (normalized units per second); a point already past
    that line returns by at most ``back`` of the step per period (0: it may stay there)."""
    scale = np.array([camera.px, camera.py])
    lo = (MARGIN_PX - np.array([camera.u0, camera.v0])) / scale
    hi = (np.array([camera.width, camera.height]) - MARGIN_PX - [camera.u0, camera.v0]) / scale
    xy = rows.s.reshape(-1, 2)
    step = np.broadcast_to(STEP_PX / scale / dt, xy.shape)
    bl = np.maximum(-step, np.minimum(XI * (lo - xy) / dt, back * step)).reshape(-1)
    bu = np.minimum(step, np.maximum(XI * (hi - xy) / dt, -back * step)).reshape(-1)
    return rows.S, bl, bu


def pair_rows(
    rows: ImageRows, camera: Camera, dt: float, back: float = RETURN
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(G, bl, bu)``: one row per pair of points (module docstring), ``bl ≤ ḋ_ij = G q̇ ≤
    bu``: the distance (normalized units, through pixels of mean focal length) closes by at
    most :data:`XI` of its gap to :data:`PAIR_PX` per period; a pair already closer must part
    at up to ``back`` of the step per period (0: it may stay), and no pair parts faster than
    two steps per period."""
    f = 0.5 * (camera.px + camera.py)
    xy, n = rows.s.reshape(-1, 2), rows.S.shape[1]
    Sxy = rows.S.reshape(-1, 2, n)
    i, j = _pairs(xy.shape[0])
    diff = xy[i] - xy[j]
    d = np.maximum(np.linalg.norm(diff, axis=1), 1e-12)
    G = np.einsum("kc,kcn->kn", diff / d[:, None], Sxy[i] - Sxy[j])
    step = STEP_PX / f / dt
    bl = np.minimum(-XI * (d - PAIR_PX / f) / dt, back * step)
    return G, bl, np.full(d.shape, 2.0 * step)


def solve_move(
    rows: ImageRows,
    lam: float,
    term: FloatArray,
    bounds: tuple[FloatArray, FloatArray],
    damper: tuple[FloatArray, FloatArray, FloatArray],
    weight: float,
) -> FloatArray | None:
    """The move's command (n,) (module docstring), or None (daqp missing or no solution)."""
    daqp = daqp_once()
    if daqp is None:  # pragma: no cover - daqp is a dependency of the qp extra
        return None
    Jg, n = rows.Jg, rows.Jg.shape[1]
    w = weight * max(float(np.linalg.norm(Jg, 2)) ** 2, 1e-12)
    H = Jg.T @ Jg + w * np.eye(n)
    f = lam * (Jg.T @ rows.eg) - w * term
    G, rl, ru = damper
    lo, hi = bounds
    bu = np.concatenate([hi, ru])
    bl = np.concatenate([lo, rl])
    sense = np.zeros(bu.size, dtype=np.intc)
    y, _, flag, _ = daqp.solve(H, f, G, bu, bl, sense)
    if flag > 0 and np.all(np.isfinite(y)):
        return np.clip(np.asarray(y, dtype=float), lo, hi)
    return None


def kept_in_image(
    model: object, q: FloatArray, qdot: FloatArray, dt: float, camera: Camera, now: FloatArray
) -> FloatArray:
    """``qdot`` halved (at most :data:`HALVINGS` times) until the model's points at
    ``q + dt q̇`` (the nonlinear prediction: at the joint speeds of a move the linear rows
    miss the drift of a fast turn by several pixels) lie within the image less half of
    :data:`MARGIN_PX`, or no further out than ``now`` (2p,), the points at ``q``, and every
    two of them half :data:`PAIR_PX` apart, or no closer than at ``q``."""
    n = q.shape[0]
    scale = np.array([camera.px, camera.py])
    lo = (MARGIN_PX / 2 - np.array([camera.u0, camera.v0])) / scale
    hi = (np.array([camera.width, camera.height]) - MARGIN_PX / 2 - [camera.u0, camera.v0]) / scale
    xy0 = now.reshape(-1, 2)
    out0 = np.maximum(lo - xy0, xy0 - hi)
    i, j = _pairs(xy0.shape[0])
    near0 = np.minimum(np.linalg.norm(xy0[i] - xy0[j], axis=1), PAIR_PX / 2 / camera.px)
    for _ in range(HALVINGS):
        pred = model.predict(q + dt * qdot, np.zeros((1, n)), horizon(1, 1), 0.0)  # type: ignore[attr-defined]
        if pred is not None and pred.s is not None:
            xy = pred.s[0].reshape(-1, 2)
            inside = np.all(np.maximum(lo - xy, xy - hi) <= np.maximum(out0, 0.0))
            if inside and np.all(np.linalg.norm(xy[i] - xy[j], axis=1) >= near0):
                return qdot
        qdot = 0.5 * qdot
    return qdot
