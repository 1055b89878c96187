"""A target's pose from its tracked dots: PnP of the known points (OpenCV ``solvePnP``).

A model-based law (the ``predictive`` law's moment model, docs/predictive.md) needs the
target's pose ``cMo``; through a camera it is not measured, but the image sensor tracks the
target's dots, whose positions on the object (``points_o``) the task knows. :func:`dot_pose`
solves the Perspective-n-Point problem on them with the camera's intrinsics:

* with a ``guess`` (the previous frame's pose brought to this camera): OpenCV's
  Levenberg-Marquardt refinement from it (``solvePnPRefineLM``, the iterative method with
  an extrinsic guess, run to :data:`_CRITERIA`), which follows the pose from frame to frame
  and keeps the branch it was on;
* without one, or when that fails: ``SOLVEPNP_IPPE`` for coplanar points (both of its
  solutions, the one with the smaller reprojection error, refined by LM) or
  ``SOLVEPNP_SQPNP`` otherwise.

A pose is accepted when every point lies in front of the camera and the RMS reprojection
error is at most ``max_rms_px`` (default :data:`MAX_RMS_PX`); otherwise, with fewer than
four dots, or with a non-finite dot, the answer is None (the caller's typed fallback).

Units: metres (points, translation), pixels (reprojection error), normalized image
coordinates for the dots (undistorted; the intrinsics turn them into ideal pixels).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import ConfigurationError, GeometryError
from redservo.kernels import compiled, lazy
from redservo.sensors import NoPose
from redservo.vision.optics import require_cv2

if TYPE_CHECKING:  # the kernel module, typed; imported on first use at run time
    from redservo.kernels import pnp_rms as _KP
else:
    _KP = lazy("pnp_rms")  # the command line starts without numba

__all__ = [
    "MAX_RMS_PX",
    "DotPose",
    "PoseMisses",
    "dot_pose",
    "pose_inv_depth",
    "pose_term_depth",
    "set_dots",
    "set_pose",
]

MAX_RMS_PX = 2.0
"""Largest RMS reprojection error (pixels) of an accepted pose: a few times the trackers'
noise (0.1-0.3 px with the ``realistic`` preset's image noise), far below what a wrong
correspondence or a wrong branch leaves (tens of pixels)."""

_CRITERIA = (3, 50, 1e-12)
"""LM's stop: ``COUNT | EPS``, 50 iterations or a step below 1e-12 (OpenCV's default, 20
and ``FLT_EPSILON``, leaves 1e-7 m on exact dots)."""
_MAX_COMPILED = 128
"""Most points whose reprojection error is computed compiled (numpy's pairwise block)."""
_PLANAR = 1e-6
"""Points whose smallest principal extent (m) is below this are treated as coplanar."""


class DotPose(NamedTuple):
    """An accepted PnP pose."""

    cMo: FloatArray
    """(4, 4) the target's frame in the camera frame (m)."""
    rms_px: float
    """RMS reprojection error of the dots (pixels)."""


def dot_pose(
    points_o: ArrayLike,
    xy: ArrayLike,
    camera: Camera | None = None,
    guess: FloatArray | None = None,
    *,
    max_rms_px: float = MAX_RMS_PX,
) -> DotPose | None:
    """The pose of the target whose points ``points_o`` (p, 3; m, its frame) are seen at
    the normalized image coordinates ``xy`` (p, 2), with ``camera``'s focal lengths and
    principal point (default :class:`~redservo.camera.Camera`), warm-started at ``guess``
    (4, 4) when given (module docstring). None when no pose is accepted."""
    P = np.ascontiguousarray(points_o, dtype=np.float64).reshape(-1, 3)
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if P.shape[0] < 4 or p.shape[0] != P.shape[0] or not np.all(np.isfinite(p)):
        return None
    K = _intrinsics(camera if camera is not None else _DEFAULT_CAMERA)
    uv = np.ascontiguousarray(p * K.focal + K.centre)
    cv2 = require_cv2()
    best: DotPose | None = None
    if guess is not None and np.all(np.isfinite(guess)):
        best = _iterative(cv2, P, uv, K, guess)
    if best is None or best.rms_px > max_rms_px:
        fresh = _fresh(cv2, P, uv, K)
        if fresh is not None and (best is None or fresh.rms_px < best.rms_px):
            best = fresh
    if best is None or not best.rms_px <= max_rms_px:
        return None
    return best


class _K(NamedTuple):
    """A camera's intrinsics as OpenCV and the reprojection take them."""

    matrix: FloatArray
    """(3, 3) the camera matrix (pixels)."""
    focal: FloatArray
    """(2,) ``(px, py)`` (pixels)."""
    centre: FloatArray
    """(2,) ``(u0, v0)`` (pixels)."""
    params: FloatArray
    """(4,) ``(px, py, u0, v0)`` (pixels), for :func:`redservo.kernels.pnp_rms.reprojection_rms`."""


_DEFAULT_CAMERA = Camera()


@lru_cache(maxsize=16)
def _intrinsics(cam: Camera) -> _K:
    """``cam``'s intrinsics, built once per camera (a frame's solve reads them; the arrays
    are never written)."""
    matrix = np.array([[cam.px, 0.0, cam.u0], [0.0, cam.py, cam.v0], [0.0, 0.0, 1.0]])
    focal, centre = np.array([cam.px, cam.py]), np.array([cam.u0, cam.v0])
    return _K(matrix, focal, centre, np.concatenate([focal, centre]))


def _pose(cv2: Any, rvec: Any, tvec: Any) -> FloatArray:
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3))[0]
    T[:3, 3] = np.asarray(tvec, dtype=np.float64).reshape(3)
    return T


def _checked(P: FloatArray, uv: FloatArray, K: _K, T: FloatArray) -> DotPose | None:
    """``T`` with its RMS reprojection error (pixels), None when a point is not in front:
    in one compiled call (:func:`redservo.kernels.pnp_rms.reprojection_rms`, the same bits)
    or here."""
    if len(P) <= _MAX_COMPILED and compiled():
        rms = _KP.reprojection_rms(P, uv, T, K.params)
        return None if rms < 0.0 else DotPose(T, rms)
    if not np.isfinite(T).all():
        return None
    Pc = P @ T[:3, :3].T + T[:3, 3]
    if not (Pc[:, 2] > 1e-6).all():
        return None
    proj = Pc[:, :2] / Pc[:, 2:3] * K.focal + K.centre
    return DotPose(T, float(np.sqrt(np.mean(np.sum((proj - uv) ** 2, axis=1)))))


def _iterative(cv2: Any, P: FloatArray, uv: FloatArray, K: _K, guess: FloatArray) -> DotPose | None:
    """LM from ``guess`` (the iterative method with the extrinsic guess)."""
    if guess[2, 3] <= 0.0:  # the target behind the camera: no start for LM
        return None
    rvec = cv2.Rodrigues(np.ascontiguousarray(guess[:3, :3], dtype=np.float64))[0]
    tvec = np.ascontiguousarray(guess[:3, 3], dtype=np.float64).reshape(3, 1)
    try:
        rvec, tvec = cv2.solvePnPRefineLM(P, uv, K.matrix, None, rvec, tvec, _CRITERIA)
    except cv2.error:
        return None
    return _checked(P, uv, K, _pose(cv2, rvec, tvec))


def _fresh(cv2: Any, P: FloatArray, uv: FloatArray, K: _K) -> DotPose | None:
    """Without a guess: IPPE (coplanar points; the better of its two solutions) or SQPnP,
    refined by LM."""
    spread = np.linalg.svd(P - P.mean(axis=0), compute_uv=False)
    method = cv2.SOLVEPNP_IPPE if spread[-1] < _PLANAR else cv2.SOLVEPNP_SQPNP
    try:
        n, rvecs, tvecs, _ = cv2.solvePnPGeneric(P, uv, K.matrix, None, flags=method)
    except cv2.error:
        return None
    best: DotPose | None = None
    for k in range(int(n)):
        try:
            rvec, tvec = cv2.solvePnPRefineLM(
                P, uv, K.matrix, None, rvecs[k].copy(), tvecs[k].copy(), _CRITERIA
            )
        except cv2.error:
            rvec, tvec = rvecs[k], tvecs[k]
        cand = _checked(P, uv, K, _pose(cv2, rvec, tvec))
        if cand is not None and (best is None or cand.rms_px < best.rms_px):
            best = cand
    return best


def pose_inv_depth(
    feature: Any, set_points: FloatArray, set_xy: FloatArray, guess: FloatArray | None
) -> tuple[FloatArray, FloatArray] | None:
    """The image sensor's ``depth = "pose"`` (:mod:`redservo.vision.depth`): the inverse-depth
    parameters of a point or moment ``feature`` (its 1/Z, 1/m; the plane ``(A, B, C)``) at
    the PnP pose of its point set (``set_points`` (N, 3), m; ``set_xy`` (N, 2) normalized,
    NaN for a dot not detected: at least four detected), warm-started at ``guess``:
    ``(inv_depth, cMo)``, or None (no accepted pose: the caller keeps the last one). The
    reprojection error is judged with the default camera's focal length (600 px)."""
    cMo = set_pose(set_points, set_xy, guess)
    if cMo is None:
        return None
    return np.asarray(feature.measure(cMo).inv_depth, dtype=float), cMo


def set_pose(
    set_points: FloatArray, set_xy: FloatArray, guess: FloatArray | None
) -> FloatArray | None:
    """The PnP pose ``cMo`` (4, 4; m) of a point set (``set_points`` (N, 3), m) from its
    detected dots (``set_xy`` (N, 2) normalized, NaN where not detected), warm-started at
    ``guess``; None when no pose is accepted (:func:`dot_pose`)."""
    P = np.asarray(set_points, dtype=float).reshape(-1, 3)
    p = np.asarray(set_xy, dtype=float).reshape(-1, 2)
    ok = np.isfinite(p).all(axis=1)
    pose = dot_pose(P[ok], p[ok], None, guess)
    return None if pose is None else pose.cMo


def set_dots(
    sets: Mapping[str, FloatArray], detected: NDArray[np.bool_], name: str, xy: FloatArray
) -> FloatArray:
    """Normalized dots (N, 2) of point set ``name`` among ``xy`` (the dots of every set of
    ``sets``, in order); NaN for the dots not ``detected`` this frame."""
    start = 0
    for other, pts in sets.items():
        if other == name:
            out = xy[start : start + len(pts)].copy()
            out[~detected[start : start + len(pts)]] = np.nan
            return out
        start += len(pts)
    raise ConfigurationError(f"no point set {name!r}")  # pragma: no cover


def pose_term_depth(
    task: Any,
    i: int,
    st: Any,
    sets: Mapping[str, FloatArray],
    detected: NDArray[np.bool_],
    xy: FloatArray,
    poses: dict[Any, FloatArray | None] | None = None,
    tried: dict[str, tuple[int, int] | None] | None = None,
) -> FloatArray | None:
    """``depth = "pose"`` for term ``i`` of ``task`` in the image sensor (its
    :class:`~redservo.vision.terms.TermState` ``st``; ``sets``, ``detected``, ``xy``: every
    point set, the dots detected this frame and every dot's normalized position): a point
    or moment term's parameters at its point set's PnP pose (:func:`pose_inv_depth`,
    warm-started at ``st.pose``, which it updates); else (another feature, no pose, a
    feature degenerate at the pose: a moment invariant that vanishes there) None,
    the caller keeping the last parameters, or the desired ones when there are none yet.

    ``poses``: the poses solved in this frame, by point set and warm start (the caller's
    dict, empty at each frame): the terms of one point set (four point terms of one
    target) share one PnP solve, the one each would get (same dots, same start).

    ``tried``: the caller's record of this frame's solves by point set (its target): None
    for a pose, ``(detected dots, points)`` for none (the ``no-pose`` flag,
    :mod:`redservo.sensors.flags`)."""
    term = task.terms[i]
    if st.kind in ("point", "moments") and st.s is not None:
        key = (term.target, None if st.pose is None else st.pose.tobytes())
        if poses is not None and key in poses:
            cMo = poses[key]
        else:
            dots = set_dots(sets, detected, term.target, xy)
            cMo = set_pose(sets[term.target], dots, st.pose)
            if poses is not None:
                poses[key] = cMo
            if tried is not None:
                seen = int(np.isfinite(dots).all(axis=1).sum())
                miss = None if cMo is not None else (seen, len(dots))
                tried[term.target] = tried.get(term.target) or miss  # a miss is kept
        if cMo is not None:
            st.pose = cMo  # a pose OpenCV's rotation vector made, checked finite: trusted
            try:
                return np.asarray(term.feature._measure_trusted(cMo).inv_depth, dtype=float)
            except GeometryError:  # the feature is degenerate at this pose (a moment
                pass  # invariant vanishes): the term keeps its last parameters, as with
                # depth = "estimated" (redservo.vision.terms.term_inv_depths)
    if st.inv_depth is None and task.inv_depth_star is not None:
        return np.asarray(task.inv_depth_star[i], dtype=float)
    return None


class PoseMisses:
    """The image sensor's frames in a row without a PnP pose, per point set (``depth =
    "pose"``; :mod:`redservo.sensors.flags`)."""

    def __init__(self) -> None:
        self.in_a_row: dict[str, int] = {}
        """Per point set (its target), the frames in a row without a pose (0 after one)."""

    def reset(self) -> None:
        """Forget the counts (start of a run)."""
        self.in_a_row.clear()

    def frame(self, tried: Mapping[str, tuple[int, int] | None]) -> NoPose | None:
        """Count this frame's solves (:func:`pose_term_depth`'s ``tried``); the point set
        without a pose for longest, or None when every solve gave one."""
        worst: NoPose | None = None
        for name, miss in tried.items():
            k = 0 if miss is None else self.in_a_row.get(name, 0) + 1
            self.in_a_row[name] = k
            if miss is not None and (worst is None or k > worst.frames):
                worst = NoPose(k, name, *miss)
        return worst
