"""Spatial algebra on plain ndarrays: transforms, rotation vectors, twists.

Conventions (``docs/conventions.md``): a transform ``aMb`` (4x4) maps coordinates
in frame b to frame a, ``X_a = aMb @ X_b``. A twist ``v = (v, w)`` (6,) stacks a
linear velocity (m/s) and an angular velocity (rad/s), both expressed in the
same frame. Rotation vectors ``theta*u`` are in radians.

The hot-path functions (``skew``, ``rotvec_to_matrix``, ``twist_transform``,
``inverse``) are written in numpy directly: building a scipy ``Rotation`` object
costs more than the arithmetic. ``scipy.spatial.transform`` serves where
robustness beats speed (``matrix_to_rotvec``, ``rpy_to_matrix``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from redservo._validation import FloatArray, as_matrix, as_vector

__all__ = [
    "exp_twist",
    "inverse",
    "log_transform",
    "make_transform",
    "matrix_to_rotvec",
    "rotvec_to_matrix",
    "rpy_to_matrix",
    "skew",
    "transform_point",
    "transform_points",
    "twist_transform",
]


def skew(w: ArrayLike) -> FloatArray:
    """Return the 3x3 skew-symmetric matrix ``[w]_x`` such that ``[w]_x @ p = w x p``."""
    x, y, z = np.asarray(w, dtype=float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotvec_to_matrix(theta_u: ArrayLike) -> FloatArray:
    """Return the rotation matrix of a rotation vector ``theta*u`` (rad), by Rodrigues' formula."""
    r = np.asarray(theta_u, dtype=float)
    theta = float(np.sqrt(r @ r))
    K = skew(r)
    if theta < 1e-8:
        # Second-order Taylor expansion; exact to machine precision here.
        return np.eye(3) + K + 0.5 * (K @ K)
    return np.eye(3) + (np.sin(theta) / theta) * K + ((1.0 - np.cos(theta)) / theta**2) * (K @ K)


def matrix_to_rotvec(R: ArrayLike) -> FloatArray:
    """Return the rotation vector ``theta*u`` (rad, ``theta`` in [0, pi]) of a rotation matrix."""
    return np.asarray(Rotation.from_matrix(as_matrix(R, "R", 3, 3)).as_rotvec(), dtype=float)


def rpy_to_matrix(rpy: ArrayLike, *, degrees: bool = False) -> FloatArray:
    """Return ``Rz(yaw) @ Ry(pitch) @ Rx(roll)`` for ``rpy = (roll, pitch, yaw)``."""
    r = as_vector(rpy, "rpy", 3)
    return np.asarray(Rotation.from_euler("ZYX", r[::-1], degrees=degrees).as_matrix(), dtype=float)


def make_transform(
    R: ArrayLike | None = None, t: ArrayLike | None = None, *, rotvec: ArrayLike | None = None
) -> FloatArray:
    """Build a 4x4 homogeneous transform.

    Args:
        R: 3x3 rotation matrix (default identity). Exclusive with ``rotvec``.
        t: Translation (3,), in metres (default zero).
        rotvec: Rotation as a rotation vector ``theta*u`` (rad).
    """
    T = np.eye(4)
    if rotvec is not None:
        T[:3, :3] = rotvec_to_matrix(as_vector(rotvec, "rotvec", 3))
    elif R is not None:
        T[:3, :3] = as_matrix(R, "R", 3, 3)
    if t is not None:
        T[:3, 3] = as_vector(t, "t", 3)
    return T


_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])


def inverse(T: FloatArray) -> FloatArray:
    """Return the inverse of a homogeneous transform (using ``R^T``, not a general inverse)."""
    TT = T.T
    Rt = TT[:3, :3]  # the view T[:3, :3].T (same strides: the same BLAS call below)
    if T.dtype == np.float64:
        out = TT.copy()  # R^T in place already: one copy instead of a block assignment
    else:
        out = np.empty((4, 4))
        out[:3, :3] = Rt
    out[:3, 3] = -(Rt @ T[:3, 3])
    out[3] = _LAST_ROW
    return out


def transform_point(T: FloatArray, p: ArrayLike) -> FloatArray:
    """Apply transform ``T`` (4x4) to one point ``p`` (3,)."""
    return np.asarray(T[:3, :3] @ np.asarray(p, dtype=float) + T[:3, 3], dtype=float)


def transform_points(T: FloatArray, P: ArrayLike) -> FloatArray:
    """Apply transform ``T`` (4x4) to points ``P`` (N, 3); returns (N, 3)."""
    return np.asarray(np.asarray(P, dtype=float) @ T[:3, :3].T + T[:3, 3], dtype=float)


def twist_transform(aMb: FloatArray) -> FloatArray:
    """Return the 6x6 velocity twist transform ``aVb`` of ``aMb = (R, t)``.

    ``aVb = [[R, [t]_x R], [0, R]]`` maps a twist expressed in frame b (about b's
    origin) to the same rigid motion expressed in frame a (about a's origin):
    ``v_a = aVb @ v_b``. With ``aMb = cMe`` this is the ``cVe`` of docs/formulas.md §1.
    """
    R = aMb[:3, :3]
    V = np.zeros((6, 6))
    V[:3, :3] = R
    V[3:, 3:] = R
    V[:3, 3:] = skew(aMb[:3, 3]) @ R
    return V


def exp_twist(twist: ArrayLike, dt: float = 1.0) -> FloatArray:
    """Return ``exp([twist]^ * dt)``, the displacement of a frame moving with a constant body twist.

    If a frame with pose ``wMc`` moves with twist ``v_c = (v, w)`` expressed in its
    own frame, its pose after ``dt`` seconds is ``wMc @ exp_twist(v_c, dt)``.

    Args:
        twist: (6,) twist ``(v, w)``, in m/s and rad/s.
        dt: Duration in seconds.
    """
    xi = np.asarray(twist, dtype=float) * dt
    v, w = xi[:3], xi[3:]
    theta = float(np.sqrt(w @ w))
    W = skew(w)
    W2 = W @ W
    if theta < 1e-8:
        R = np.eye(3) + W + 0.5 * W2
        V = np.eye(3) + 0.5 * W + W2 / 6.0
    else:
        R = np.eye(3) + (np.sin(theta) / theta) * W + ((1 - np.cos(theta)) / theta**2) * W2
        V = (
            np.eye(3)
            + ((1 - np.cos(theta)) / theta**2) * W
            + ((theta - np.sin(theta)) / theta**3) * W2
        )
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = V @ v
    return T


def log_transform(T: ArrayLike) -> FloatArray:
    """Return the twist ``xi`` (6,) with ``exp_twist(xi) == T`` (inverse of :func:`exp_twist`)."""
    M = as_matrix(T, "T", 4, 4)
    w = matrix_to_rotvec(M[:3, :3])
    theta = float(np.linalg.norm(w))
    W = skew(w)
    if theta < 1e-8:
        Vinv = np.eye(3) - 0.5 * W + (W @ W) / 12.0
    else:
        half = 0.5 * theta
        coef = (1.0 - half * np.cos(half) / np.sin(half)) / theta**2
        Vinv = np.eye(3) - 0.5 * W + coef * (W @ W)
    return np.concatenate([Vinv @ M[:3, 3], w])
