"""Manipulability of the task: Yoshikawa's measure, its gradient, an objective, a margin.

For the task Jacobian ``J1 = A J(q)`` (``A = C L``, m x 6, the interaction with the
features frozen over the step; ``J`` the camera's (6, n) Jacobian, twist ``[v; ω]`` in the
camera frame) Yoshikawa's measure (1985) is ``w = sqrt(det(J1 J1ᵀ))`` (0 at a singular
configuration of the task). Its gradient::

    ∂w/∂q_i = w tr((J1 J1ᵀ)⁻¹ A (∂J/∂q_i) J1ᵀ)

with the derivative of the camera-frame (body) Jacobian of a serial chain in closed form,
column by column: ``∂J_j/∂q_i = ad(J_j) J_i`` for ``i > j`` and 0 otherwise, ``ad(v, ω) =
[[ω×, v×], [0, ω×]]`` (the Lie bracket of the joint twists; Murray, Li & Sastry 1994,
§3.4; Haviland & Corke 2022 for the same result in the base frame).
:func:`jacobian_derivative` checks that closed form once per robot against central finite
differences and uses the differences for a robot whose joints are not a plain serial chain
(the Afma6's coupled wrist).

* :class:`Manipulability` is an objective (:mod:`redservo.control.objectives`): the joint
  velocity ``k ∇w`` (``gain`` ``k``) as the law's ``secondary``, projected by its operator;
  in ``qp`` it is the preferred velocity of the cost ``ε ‖q̇ − k ∇w‖²``, in ``sns`` the
  initial ``q̇_N``.
* :class:`SingularityMargin` gives the summary's ``min_manipulability`` (``w``) and
  ``min_singular_value`` (``σ_min(J1)``), the distance of the run to a task singularity.

Units: ``w`` in the units of ``J1`` to the power ``m``; ``∇w`` per rad or per m.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.control.objectives import ObjectiveContext
from redservo.errors import ConfigurationError
from redservo.robots.base import Robot

__all__ = [
    "Manipulability",
    "SingularityMargin",
    "jacobian_derivative",
    "manipulability",
    "manipulability_gradient",
]

_FD_STEP = 1e-6
"""Central-difference step (rad or m)."""
_CLOSED_FORM: dict[int, bool] = {}
"""Per robot (``id``): whether the closed-form derivative holds (checked once)."""


def manipulability(J1: FloatArray) -> float:
    """Yoshikawa's ``w = sqrt(det(J1 J1ᵀ))`` of an (m, n) matrix (0 when singular)."""
    return float(np.sqrt(max(float(np.linalg.det(J1 @ J1.T)), 0.0)))


def _ad(a: FloatArray, b: FloatArray) -> FloatArray:
    va, wa, vb, wb = a[:3], a[3:], b[:3], b[3:]
    return np.concatenate([np.cross(wa, vb) + np.cross(va, wb), np.cross(wa, wb)])


def _closed_form(J: FloatArray) -> FloatArray:
    n = J.shape[1]
    dJ = np.zeros((n, 6, n))
    for i in range(n):
        for j in range(i):
            dJ[i, :, j] = _ad(J[:, j], J[:, i])
    return dJ


def _differences(robot: Robot, q: FloatArray) -> FloatArray:
    n = robot.n
    dJ = np.zeros((n, 6, n))
    for i in range(n):
        dq = np.zeros(n)
        dq[i] = _FD_STEP
        plus = robot.jacobian(q + dq, check_limits=False)
        minus = robot.jacobian(q - dq, check_limits=False)
        dJ[i] = (plus - minus) / (2.0 * _FD_STEP)
    return dJ


def jacobian_derivative(robot: Robot, q: FloatArray, J: FloatArray | None = None) -> FloatArray:
    """(n, 6, n) ``∂J/∂q_i`` of ``robot``'s camera Jacobian at ``q`` (module docstring):
    the closed form once checked against differences for this robot, else the differences."""
    Jq = robot.jacobian(q, check_limits=False) if J is None else J
    ok = _CLOSED_FORM.get(id(robot))
    if ok is None:
        fd = _differences(robot, q)
        scale = max(1.0, float(np.max(np.abs(fd))))
        ok = _CLOSED_FORM[id(robot)] = bool(np.max(np.abs(_closed_form(Jq) - fd)) < 1e-6 * scale)
        if not ok:
            return fd
    return _closed_form(Jq) if ok else _differences(robot, q)


def manipulability_gradient(
    A: FloatArray, J: FloatArray, dJ: FloatArray, damping: float = 1e-12
) -> tuple[float, FloatArray]:
    """``(w, ∇w)`` of ``J1 = A J`` (module docstring) with ``dJ`` = (n, 6, n) ``∂J/∂q_i``;
    ``damping`` (units of ``J1 J1ᵀ``) keeps the solve finite at a singularity."""
    J1 = A @ J
    M = J1 @ J1.T
    w = manipulability(J1)
    X = np.linalg.solve(M + damping * np.eye(M.shape[0]), J1)  # (J1 J1ᵀ)⁻¹ J1
    AdJ = np.einsum("mk,ikn->imn", A, dJ)  # A ∂J/∂q_i, (n, m, n)
    grad = w * np.einsum("mn,imn->i", X, AdJ)
    return w, np.asarray(grad)


def _task_map(J1: FloatArray, J: FloatArray) -> FloatArray:
    """``A`` with ``J1 = A J`` (exact when ``J`` has rank 6), by least squares."""
    return np.asarray(np.linalg.lstsq(J.T, J1.T, rcond=None)[0].T)


@dataclass
class Manipulability:
    """Objective: ``gain ∇w`` (rad/s or m/s) as the law's ``secondary`` (module docstring),
    moving the redundancy away from task singularities.

    Args:
        gain: ``k`` (> 0): joint velocity per unit of ``∇w``.
    """

    gain: float = 1.0

    def __post_init__(self) -> None:
        g = self.gain
        if isinstance(g, bool) or not isinstance(g, int | float) or not (0.0 < g < np.inf):
            raise ConfigurationError(
                f"gain must be a finite number > 0, got {g!r}", argument="gain"
            )

    def __call__(self, ctx: ObjectiveContext) -> tuple[FloatArray | None, str | None]:
        if ctx.robot is None:
            raise ConfigurationError(
                "Manipulability needs the controller's model robot", argument="objectives"
            )
        dJ = jacobian_derivative(ctx.robot, ctx.q, ctx.J)
        _, grad = manipulability_gradient(_task_map(ctx.state.J1, ctx.J), ctx.J, dJ)
        return self.gain * grad, None


@dataclass
class SingularityMargin:
    """The run's smallest ``w`` and ``σ_min`` of the task Jacobian (:meth:`add` per step).

    The Jacobians are kept (copied into one growing stack) and reduced when the margin is
    read (:meth:`fields`, :attr:`w`, :attr:`sigma`): numpy's SVD (``compute_uv=False``) and
    ``det(J1 J1ᵀ)`` of the whole stack in one call each, which run the same LAPACK and BLAS
    routines on each matrix as one call per step did (the same bits,
    tests/test_singularity_margin.py), without numpy's Python around each small call."""

    _w: float = float("inf")
    _sigma: float = float("inf")
    steps: int = field(default=0)
    _stack: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 0)), repr=False)
    _kept: int = field(default=0, repr=False)
    """How many Jacobians :attr:`_stack` holds that are not reduced yet."""
    chunk: int = field(default=1024, repr=False)
    """The most Jacobians kept at once: a full stack is reduced and reused, so a long run's
    memory stays bounded (the minima are the same however the steps are grouped)."""

    @property
    def w(self) -> float:
        """The smallest ``w`` so far (inf: no step)."""
        self._reduce()
        return self._w

    @property
    def sigma(self) -> float:
        """The smallest ``σ_min(J1)`` so far (inf: no step)."""
        self._reduce()
        return self._sigma

    def add(self, J1: FloatArray) -> None:
        """Count the (m, n) task Jacobian of one step (a copy is kept until it is reduced)."""
        stack, kept = self._stack, self._kept
        if stack.shape[1:] != J1.shape:
            self._reduce()
            stack = self._stack = np.empty((min(64, self.chunk), *J1.shape))
            kept = 0
        elif kept == stack.shape[0] >= self.chunk:
            self._reduce()
            kept = 0
        elif kept == stack.shape[0]:
            grown = np.empty((min(2 * kept, self.chunk), *J1.shape))
            grown[:kept] = stack
            stack = self._stack = grown
        stack[kept] = J1
        self._kept = kept + 1
        self.steps += 1

    def _reduce(self) -> None:
        """Fold the kept Jacobians into :attr:`w` and :attr:`sigma`, in step order, as
        ``min(w, manipulability(J1))`` and ``min(σ, σ_min(J1))`` per step did."""
        kept = self._kept
        if not kept:
            return
        J = self._stack[:kept]
        self._kept = 0
        sv = np.linalg.svd(J, compute_uv=False)
        dets = np.linalg.det(J @ J.transpose(0, 2, 1)).tolist()
        last = sv[:, -1].tolist() if sv.shape[1] else [0.0] * kept
        w, sigma = self._w, self._sigma
        for d, s in zip(dets, last, strict=True):
            w = min(w, float(np.sqrt(max(d, 0.0))))
            sigma = min(sigma, s)
        self._w, self._sigma = w, sigma

    def fields(self) -> dict[str, Any]:
        """The summary's ``min_manipulability`` and ``min_singular_value`` (None: no step)."""
        if not self.steps:
            return {"min_manipulability": None, "min_singular_value": None}
        return {"min_manipulability": self.w, "min_singular_value": self.sigma}
