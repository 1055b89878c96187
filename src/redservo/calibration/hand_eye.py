"""Hand-eye calibration from pairs of robot and target poses (``cv2.calibrateHandEye``).

Input: K >= 3 pairs ``(wMe_k, cMo_k)``: the end-effector pose in the robot's base (world)
frame, read from the robot, and the calibration target's pose in the camera frame, e.g.
from ``cv2.solvePnP`` or the per-image poses of ``redservo calibrate``. Motions between
the stations should turn about at least two different axes.

* ``mount = "hand"`` (eye-in-hand): the camera rides on the effector, the target is fixed
  in the world. Unknown ``eMc``; ``wMe_k · eMc · cMo_k = wMo`` for every k.
  ``cv2.calibrateHandEye(wRe, wte, cRo, cto)`` returns ``eMc`` ("cam2gripper").
* ``mount = "world"`` (eye-to-hand): the camera is fixed, the target rides on the
  effector. Unknown ``wMc``; ``inv(wMe_k) · wMc · cMo_k = eMo`` for every k. The same
  solver given the inverted robot poses ``eMw_k`` returns ``wMc`` (OpenCV's documented
  eye-to-hand use).

Residuals: the other unknown (``wMo``, resp. ``eMo``) computed from each pair should be one
pose; the result reports the spread of those K poses around their mean: RMS and largest
rotation (degrees) and translation (m) deviations.

Pose files: :func:`~redservo.calibration.pose_file.load_pose_pairs` (JSON or CSV, validated).

Mount mismatch: pairs recorded with the camera on the hand but solved with ``mount =
"world"`` (or the reverse) have no consistent solution. When the solution for the given
mount fails or leaves residuals over :data:`MISMATCH_DEG` / :data:`MISMATCH_M`, the other
mount is solved too; if it fits (within those), the error says so and names the mount.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from redservo._validation import FloatArray, as_transform
from redservo.calibration.pose_file import CSV_COLUMNS, load_pose_pairs
from redservo.errors import ConfigurationError
from redservo.spatial import inverse, make_transform, matrix_to_rotvec

__all__ = [
    "CSV_COLUMNS",
    "METHODS",
    "MISMATCH_DEG",
    "MISMATCH_M",
    "HandEyeResult",
    "Mount",
    "hand_eye",
    "load_pose_pairs",
    "park_martin",
    "pose_toml",
]

Mount = Literal["hand", "world"]
METHODS = ("tsai", "park", "horaud", "andreff", "daniilidis")
"""The solvers of ``cv2.calibrateHandEye`` (``CALIB_HAND_EYE_*``)."""
MISMATCH_DEG = 2.0
"""Rotation residual (deg RMS) above which the other mount is tried (module docstring)."""
MISMATCH_M = 0.02
"""Translation residual (m RMS) above which the other mount is tried."""


@dataclass
class HandEyeResult:
    """What :func:`hand_eye` found."""

    mount: Mount
    X: FloatArray
    """``eMc`` (mount ``hand``) or ``wMc`` (mount ``world``), 4x4 (m)."""
    other: FloatArray
    """The mean of the other unknown: ``wMo`` (hand) or ``eMo`` (world), 4x4."""
    rot_rms_deg: float
    rot_max_deg: float
    trans_rms_m: float
    trans_max_m: float
    n_pairs: int
    solver: str = ""
    """Which solver ran (OpenCV's, or the Park-Martin fallback)."""

    @property
    def name(self) -> str:
        """``eMc`` or ``wMc``."""
        return "eMc" if self.mount == "hand" else "wMc"


def _mean_pose(Ts: Sequence[FloatArray]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Mean pose, rotation deviations (rad) and translation deviations (m) of each."""
    from scipy.spatial.transform import Rotation

    rots = Rotation.from_matrix(np.array([T[:3, :3] for T in Ts]))
    mean_R = rots.mean()
    t = np.array([T[:3, 3] for T in Ts])
    mean = make_transform(mean_R.as_matrix(), t.mean(axis=0))
    dr = (mean_R.inv() * rots).magnitude()
    dt = np.linalg.norm(t - t.mean(axis=0), axis=1)
    return mean, np.asarray(dr), np.asarray(dt)


def hand_eye(
    wMe: Sequence[FloatArray],
    cMo: Sequence[FloatArray],
    *,
    mount: Mount = "hand",
    method: str = "tsai",
) -> HandEyeResult:
    """Solve the hand-eye problem of ``mount`` (module docstring).

    Args:
        wMe: K robot poses (4x4, m), the end effector in the base frame.
        cMo: K target poses (4x4, m) in the camera frame, same order.
        mount: ``"hand"`` (eye-in-hand, gives ``eMc``) or ``"world"`` (eye-to-hand, ``wMc``).
        method: One of :data:`METHODS`.

    Raises:
        ConfigurationError: fewer than 3 pairs, different counts, an unknown method/mount,
            no rigid solution, or pairs that fit the other mount (the message says so).
        ShapeError: a pose is not a rigid transform.
    """
    from redservo.vision.optics import require_cv2

    cv2 = require_cv2()
    if mount not in ("hand", "world"):
        raise ConfigurationError(
            f"mount must be 'hand' or 'world', got {mount!r}", argument="mount"
        )
    if method not in METHODS:
        raise ConfigurationError(
            f"method must be one of {', '.join(METHODS)}, got {method!r}", argument="method"
        )
    if len(wMe) != len(cMo):
        raise ConfigurationError(f"{len(wMe)} robot poses but {len(cMo)} target poses")
    if len(wMe) < 3:
        raise ConfigurationError(
            f"hand-eye calibration needs at least 3 pose pairs, got {len(wMe)}"
        )
    A = [as_transform(T, f"wMe[{k}]") for k, T in enumerate(wMe)]
    B = [as_transform(T, f"cMo[{k}]") for k, T in enumerate(cMo)]
    res: HandEyeResult | None = None
    try:
        res = _solve(cv2, A, B, mount, method)
    except ConfigurationError as exc:
        failure = exc
    if res is None or res.rot_rms_deg > MISMATCH_DEG or res.trans_rms_m > MISMATCH_M:
        _check_mount(cv2, A, B, mount, method, res)
    if res is None:
        raise failure
    return res


def _residuals(res: HandEyeResult | None) -> str:
    if res is None:
        return "no rigid solution"
    return f"residuals {res.rot_rms_deg:.3g} deg, {res.trans_rms_m * 1e3:.3g} mm RMS"


def _check_mount(
    cv2: Any,
    A: list[FloatArray],
    B: list[FloatArray],
    mount: Mount,
    method: str,
    res: HandEyeResult | None,
) -> None:
    """Raise ConfigurationError when the pairs fit the other mount (module docstring)."""
    other: Mount = "world" if mount == "hand" else "hand"
    try:
        alt = _solve(cv2, A, B, other, method)
    except ConfigurationError:
        return
    if alt.rot_rms_deg <= MISMATCH_DEG and alt.trans_rms_m <= MISMATCH_M:
        raise ConfigurationError(
            f"these pose pairs fit mount '{other}' ({_residuals(alt)}), not mount '{mount}' "
            f"({_residuals(res)}): mount 'hand' is a camera riding on the effector with the "
            "target fixed in the world, 'world' a fixed camera with the target riding on the "
            f"effector; use --mount {other}",
            argument="mount",
        )


def _solve(
    cv2: Any, A: list[FloatArray], B: list[FloatArray], mount: Mount, method: str
) -> HandEyeResult:
    """The solution for ``mount`` and its residuals (module docstring)."""
    robot = A if mount == "hand" else [inverse(T) for T in A]
    if hasattr(cv2, "calibrateHandEye"):
        flag = getattr(cv2, f"CALIB_HAND_EYE_{method.upper()}")
        R, t = cv2.calibrateHandEye(
            [T[:3, :3] for T in robot],
            [T[:3, 3] for T in robot],
            [T[:3, :3] for T in B],
            [T[:3, 3] for T in B],
            method=flag,
        )
        R = np.asarray(R, dtype=float)
        if not (np.isfinite(R).all() and np.linalg.det(R) > 0.5):
            raise ConfigurationError(
                "cv2.calibrateHandEye found no rotation: the pose pairs are degenerate"
            )
        X = make_transform(R, np.ravel(t))
        solver = f"cv2.calibrateHandEye ({method})"
    else:
        X = park_martin(robot, B)
        solver = "Park-Martin (this OpenCV build has no calibrateHandEye)"
    if mount == "hand":
        others = [a @ X @ b for a, b in zip(A, B, strict=True)]  # wMo
    else:
        others = [inverse(a) @ X @ b for a, b in zip(A, B, strict=True)]  # eMo
    mean, dr, dt = _mean_pose(others)
    deg = np.degrees(dr)
    rot_rms, trans_rms = float(np.sqrt(np.mean(deg**2))), float(np.sqrt(np.mean(dt**2)))
    return HandEyeResult(
        mount, X, mean, rot_rms, float(deg.max()), trans_rms, float(dt.max()), len(A), solver
    )


def park_martin(gMb: Sequence[FloatArray], cMt: Sequence[FloatArray]) -> FloatArray:
    """``X`` with ``gMb_k · X · cMt_k`` constant, by Park & Martin's closed form (IEEE TRA
    1994): with the relative motions ``A = inv(gMb_j) gMb_i`` and ``B = cMt_j inv(cMt_i)``
    of every pair ``i < j`` (``A X = X B``), ``R_X = (MᵀM)^(-1/2) Mᵀ`` with
    ``M = Σ log(R_B) log(R_A)ᵀ``, then ``t_X`` by linear least squares on
    ``(R_A − I) t_X = R_X t_B − t_A``. The fallback of :func:`hand_eye` when OpenCV lacks
    ``calibrateHandEye`` (the same method as its ``CALIB_HAND_EYE_PARK``).

    Raises:
        ConfigurationError: the motions do not turn about two different axes.
    """
    As, Bs = [], []
    for i in range(len(gMb)):
        for j in range(i + 1, len(gMb)):
            As.append(inverse(gMb[j]) @ gMb[i])
            Bs.append(cMt[j] @ inverse(cMt[i]))
    M = np.zeros((3, 3))
    for a, b in zip(As, Bs, strict=True):
        M += np.outer(matrix_to_rotvec(b[:3, :3]), matrix_to_rotvec(a[:3, :3]))
    w, V = np.linalg.eigh(M.T @ M)
    if w[0] <= 1e-12 * max(w[-1], 1e-300):
        raise ConfigurationError(
            "the robot motions between the poses turn about fewer than two axes; hand-eye "
            "calibration needs rotations about at least two different axes"
        )
    R = V @ np.diag(w**-0.5) @ V.T @ M.T
    if not np.linalg.det(R) > 0.0:
        raise ConfigurationError(
            "the robot's and the target's motions fit no rigid hand-eye transform (the best "
            "fit is a reflection): the pose pairs do not belong together"
        )
    C = np.vstack([a[:3, :3] - np.eye(3) for a in As])
    d = np.concatenate([R @ b[:3, 3] - a[:3, 3] for a, b in zip(As, Bs, strict=True)])
    t = np.linalg.lstsq(C, d, rcond=None)[0]
    return make_transform(R, t)


def _fmt(values: FloatArray) -> str:
    return "[" + ", ".join(f"{float(v):.6g}" for v in values) + "]"


def pose_toml(result: HandEyeResult) -> str:
    """The result in the scenario format: ``[robot] eMc`` or ``[camera] mount/pose``."""
    X = result.X
    pose = f"{{ translation = {_fmt(X[:3, 3])}, rotvec = {_fmt(matrix_to_rotvec(X[:3, :3]))} }}"
    head = (
        f"# hand-eye calibration ({result.n_pairs} pose pairs): residuals "
        f"{result.rot_rms_deg:.3g} deg RMS ({result.rot_max_deg:.3g} max), "
        f"{result.trans_rms_m * 1e3:.3g} mm RMS ({result.trans_max_m * 1e3:.3g} max)\n"
    )
    if result.mount == "hand":
        return head + f"[robot]\neMc = {pose}   # camera in the end-effector frame (URDF robots)\n"
    return head + f'[camera]\nmount = "world"\npose = {pose}   # wMc, the fixed camera\n'
