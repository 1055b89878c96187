"""Artificial forces for the secondary task: joint limits and occlusions (MC05 §IV-B, IV-C).

A cost ``V`` is written in the space ``Φ`` where the obstacle lives and pulled back
to joint space by MC05 eq. 27,

    ``F_Φ(q) = -(∂Φ/∂q)^+ ∇_Φ V``,

a joint-velocity command (rad/s or m/s per axis) that descends ``V``. Both forces
here are meant as the ``secondary`` input of a law (``directional`` projects it
with MC05's non-linear operator, the other laws with ``J1^⊥``).

Joint limits (MC05 eqs. 28-29, identical to CM01 eqs. 3-6): ``Φ = q``, so
``∂Φ/∂q = I`` and the force is ``-κ e2`` with ``e2 = ∇V = JointLimits.gradient(q)``.

Occlusions (MC05 eqs. 30-31): ``V = exp(-β d²)`` with ``d = ||p_a - p_t||`` the image
distance (normalized coordinates) between ``p_a``, the point of the occluding
object closest to the target, and ``p_t``, the target point. ``Φ = p_a`` and
``∂p_a/∂q = H = L_pa J(q)`` (2 x n), so ``F = -H^+ ∇_pa V`` with

    ``∇_pa V = -2 β exp(-β d²) (p_a - p_t)``   (no division by d: smooth at d = 0).

Sign check: applying ``q̇ = F`` moves the occluder's image as
``ṗ_a = H F = -H H^+ ∇V``, so ``dV/dt = -∇V^T H H^+ ∇V <= 0`` (``H H^+`` is an
orthogonal projector); V decreases strictly with d, hence d grows, with equality
only when ``∇V`` is orthogonal to the range of H.

Decisions (the paper is silent; recorded for docs/decisions.md):

* The target point ``p_t`` is held fixed when differentiating, as in MC05 eq. 31
  (the gradient is taken with respect to ``p_a`` only); the target's image motion
  is governed by the main task.
* At ``d = 0`` the cost is maximal and its gradient is exactly zero, so the force is
  zero: the escape direction is undefined there. No NaN is produced.
* ``H`` may be given directly (2 x n) or as the camera-space ``L_pa`` (2 x 6)
  together with ``J`` (6 x n) through the ``J`` keyword; ``H = L_pa J`` then.
* The joint-limit force is defined beyond the real limits too (the excess keeps
  growing linearly), so ``q`` is only checked for shape and finiteness.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_matrix, as_vector
from redservo.errors import ConfigurationError, ShapeError
from redservo.limits import JointLimits
from redservo.redundancy.linalg import DEFAULT_RCOND, pinv

__all__ = [
    "OcclusionForce",
    "joint_limit_force",
    "occlusion_cost",
    "occlusion_force",
    "occlusion_gradient",
]


def _positive(value: float, name: str, meaning: str) -> float:
    v = float(value)
    if not (np.isfinite(v) and v > 0.0):
        raise ConfigurationError(
            f"{name} ({meaning}) must be a finite positive number, got {value!r}"
        )
    return v


def joint_limit_force(q: ArrayLike, limits: JointLimits, *, kappa: float = 1.0) -> FloatArray:
    """Return the joint-limit artificial force ``-κ e2`` (MC05 eqs. 27-29), shape (n,).

    ``e2_i = s_i / Δq̄_i`` is the gradient of the cost ``1/2 Σ s_i²/Δq̄_i``
    (:meth:`JointLimits.gradient`); it is zero between the activation thresholds
    and points toward the nearer limit inside the band, so the force pushes each
    axis in the band back toward the middle of its range.

    Args:
        q: (n,) joint positions (m or rad).
        limits: The robot's :class:`~redservo.JointLimits`.
        kappa: Gain κ > 0, in joint units per second per unit of ``e2``
            (``e2`` is dimensionless and at most ``rho`` at a real limit).

    Returns:
        (n,) joint-velocity command (m/s or rad/s per axis).

    Raises:
        ShapeError: ``q`` is not a finite (n,) vector.
        ConfigurationError: ``kappa`` is not finite and positive.
    """
    k = _positive(kappa, "kappa", "joint-limit force gain κ")
    qa = as_vector(q, "q", limits.n)
    return np.asarray(-k * limits.gradient(qa), dtype=float)


def occlusion_cost(d: float, *, beta: float) -> float:
    """Return the occlusion cost ``V = exp(-β d²)`` (MC05 eq. 30).

    Args:
        d: Image distance between the occluder and the target (normalized units), >= 0.
        beta: Sharpness β > 0 (1/normalized-unit²); V falls to ``e^-1`` at ``d = 1/sqrt(β)``.

    Raises:
        ConfigurationError: ``beta`` is not finite and positive.
        ShapeError: ``d`` is negative or not finite.
    """
    b = _positive(beta, "beta", "occlusion cost sharpness β")
    dist = float(d)
    if not (np.isfinite(dist) and dist >= 0.0):
        raise ShapeError(f"d (image distance) must be finite and >= 0, got {d!r}")
    return float(np.exp(-b * dist * dist))


def occlusion_gradient(p_occluder: ArrayLike, p_target: ArrayLike, *, beta: float) -> FloatArray:
    """Return ``∇_pa V`` (2,), the gradient of ``exp(-β ||p_a - p_t||²)`` wrt ``p_a``.

    ``∇_pa V = -2 β exp(-β d²) (p_a - p_t)``; it points from the occluder toward the
    target (V grows as they approach) and is exactly zero at ``d = 0``.

    Args:
        p_occluder: (2,) image point ``p_a = (x_a, y_a)`` (normalized coordinates).
        p_target: (2,) image point ``p_t = (x, y)`` of the target.
        beta: Sharpness β > 0.
    """
    b = _positive(beta, "beta", "occlusion cost sharpness β")
    pa = as_vector(p_occluder, "p_occluder", 2)
    pt = as_vector(p_target, "p_target", 2)
    diff = pa - pt
    return np.asarray(-2.0 * b * np.exp(-b * float(diff @ diff)) * diff, dtype=float)


class OcclusionForce(NamedTuple):
    """The occlusion-avoidance force and the quantities it came from."""

    force: FloatArray
    """(n,) joint-velocity command ``-H^+ ∇_pa V`` (MC05 eq. 31)."""
    cost: float
    """``V = exp(-β d²)`` (MC05 eq. 30), in (0, 1]."""
    distance: float
    """``d = ||p_a - p_t||`` (normalized image units)."""
    gradient: FloatArray
    """(2,) ``∇_pa V``."""


def occlusion_force(
    p_occluder: ArrayLike,
    p_target: ArrayLike,
    H: ArrayLike,
    *,
    beta: float,
    J: ArrayLike | None = None,
    rcond: float = DEFAULT_RCOND,
) -> OcclusionForce:
    """Return the occlusion-avoidance artificial force of MC05 eq. 31.

    ``F = -H^+ ∇_pa V`` with ``H = L_pa J(q)`` the joint-space interaction matrix
    of the occluder's image point. A small step along F increases the image
    distance d (see the module docstring for the proof); at ``d = 0`` F is zero.

    Args:
        p_occluder: (2,) ``p_a = (x_a, y_a)``, the occluder's image point closest to
            the target (normalized coordinates).
        p_target: (2,) ``p_t = (x, y)``, the target point to keep clear.
        H: (2, n) ``L_pa J(q)``, with ``ṗ_a = H q̇``. If ``J`` is given, H is
            instead the (2, 6) camera-space interaction matrix ``L_pa``
            (``ṗ_a = L_pa v_c``) and ``L_pa @ J`` is formed here.
        beta: Sharpness β > 0 of the cost (1/normalized-unit²).
        J: Optional (6, n) robot Jacobian ``v_c = J(q) q̇`` (docs/formulas.md §1).
        rcond: Relative singular-value cut-off of the pseudo-inverse ``H^+``.

    Returns:
        :class:`OcclusionForce` with ``force`` (n,), ``cost``, ``distance``, ``gradient`` (2,).

    Raises:
        ShapeError: wrong shapes or non-finite values.
        ConfigurationError: ``beta`` not positive, or ``rcond`` outside (0, 1).
    """
    if not (0.0 < float(rcond) < 1.0):
        raise ConfigurationError(f"rcond must lie in (0, 1), got {rcond!r}")
    grad = occlusion_gradient(p_occluder, p_target, beta=beta)
    if J is None:
        Hm = as_matrix(H, "H", 2)
    else:
        L = as_matrix(H, "H (the camera-space L_pa, since J is given)", 2, 6)
        Jm = as_matrix(J, "J", 6)
        Hm = L @ Jm
    if Hm.shape[1] == 0:
        raise ShapeError("H must have at least one column (one joint)")
    diff = as_vector(p_occluder, "p_occluder", 2) - as_vector(p_target, "p_target", 2)
    d = float(np.sqrt(diff @ diff))
    force = -(pinv(Hm, float(rcond)) @ grad)
    return OcclusionForce(np.asarray(force, dtype=float), occlusion_cost(d, beta=beta), d, grad)
