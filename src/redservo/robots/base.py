"""The robot interface shared by every model.

A robot carries an eye-in-hand camera. ``fkine(q)`` is the camera pose ``bMc``
in the base frame and ``jacobian(q)`` is the 6 x n matrix ``J(q)`` of the
papers, ``v_c = J(q) q̇``, with ``v_c = (v, ω)`` the camera twist expressed in
the camera frame (docs/formulas.md §1): ``J(q) = cVe · eJe(q)``.

Subclasses implement ``fkine_ee(q)`` (``bMe``, 4x4) and ``jacobe(q)`` (``eJe``,
6 x n: the end-effector twist ``(v_e, ω_e)`` expressed in the end-effector frame,
``v_e`` the velocity of the end-effector origin). Units: metres, radians, seconds.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform, as_vector
from redservo.errors import ConfigurationError, JointLimitError, ShapeError
from redservo.limits import JointLimits
from redservo.spatial import inverse, log_transform, twist_transform

__all__ = ["JointType", "Robot"]

JointType = Literal["revolute", "prismatic"]


class Robot(abc.ABC):
    """A serial robot with an eye-in-hand camera.

    Args:
        name: Model name.
        joint_names: One name per joint.
        joint_types: ``"revolute"`` or ``"prismatic"`` per joint.
        q_min: (n,) lower joint limits (m or rad).
        q_max: (n,) upper joint limits (m or rad).
        eMc: 4x4 hand-eye transform, the camera pose in the end-effector frame
            (default identity).
        qdot_max: Joint velocity limits (rad/s or m/s), scalar or (n,), or None.
        qddot_max: Joint acceleration limits (rad/s² or m/s²), scalar or (n,), or None.
    """

    def __init__(
        self,
        *,
        name: str,
        joint_names: Sequence[str],
        joint_types: Sequence[JointType],
        q_min: ArrayLike,
        q_max: ArrayLike,
        eMc: ArrayLike | None = None,
        qdot_max: ArrayLike | None = None,
        qddot_max: ArrayLike | None = None,
    ) -> None:
        n = len(joint_names)
        if len(joint_types) != n:
            raise ShapeError(f"{n} joint names but {len(joint_types)} joint types")
        bad = [t for t in joint_types if t not in ("revolute", "prismatic")]
        if bad:
            raise ConfigurationError(
                f"joint types must be 'revolute' or 'prismatic', got {bad[0]!r}"
            )
        self.name = name
        self.joint_names: tuple[str, ...] = tuple(joint_names)
        self.joint_types: tuple[JointType, ...] = tuple(joint_types)
        self._limits = JointLimits(
            as_vector(q_min, "q_min", n),
            as_vector(q_max, "q_max", n),
            qdot_max=qdot_max,
            qddot_max=qddot_max,
        )
        self.eMc = np.eye(4) if eMc is None else eMc

    def kernel_pack(self) -> tuple[Any, ...] | None:
        """This robot as the compiled engine takes it (:mod:`redservo.robots.pack`), or None
        when its kinematics is not compiled (the engine then asks :meth:`jacobian`).

        The robot kinds with compiled kinematics override it; a subclass that overrides
        :meth:`kinematics` gets None, so the engine never runs a model other than the
        robot's own."""
        return None

    # -- identity ---------------------------------------------------------------------------

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.joint_names)

    @property
    def q_min(self) -> FloatArray:
        """(n,) lower joint limits (m or rad)."""
        return self._limits.q_min

    @property
    def q_max(self) -> FloatArray:
        """(n,) upper joint limits (m or rad)."""
        return self._limits.q_max

    @property
    def qlim(self) -> FloatArray:
        """(2, n) limits, ``[q_min; q_max]`` (roboticstoolbox naming)."""
        return np.vstack([self.q_min, self.q_max])

    @property
    def qdot_max(self) -> FloatArray | None:
        """(n,) joint velocity limits (rad/s or m/s), or None when unknown."""
        return self._limits.qdot_max

    @property
    def qddot_max(self) -> FloatArray | None:
        """(n,) joint acceleration limits (rad/s² or m/s²), or None when unknown."""
        return self._limits.qddot_max

    def limits(self, rho: float = 0.1, *, margin: float = 0.0) -> JointLimits:
        """Return the :class:`~redservo.JointLimits` of this robot: position limits with band
        width ``rho``, the robot's velocity and acceleration limits, and the shield's keep-out
        ``margin`` (fraction of each range, default 0)."""
        if rho == self._limits.rho and margin == 0.0:
            return self._limits
        return self._limits.replace(rho=rho, margin=margin)

    def set_limits(
        self,
        q_min: ArrayLike | None = None,
        q_max: ArrayLike | None = None,
        *,
        qdot_max: ArrayLike | str | None = "keep",
        qddot_max: ArrayLike | str | None = "keep",
    ) -> None:
        """Replace some of the joint limits: positions (m or rad), velocities (rad/s or m/s),
        accelerations (rad/s² or m/s²). ``"keep"`` (default) keeps the current rate limits and
        ``None`` removes them."""
        old = self._limits
        self._limits = JointLimits(
            old.q_min if q_min is None else as_vector(q_min, "q_min", self.n),
            old.q_max if q_max is None else as_vector(q_max, "q_max", self.n),
            qdot_max=old.qdot_max if isinstance(qdot_max, str) else qdot_max,
            qddot_max=old.qddot_max if isinstance(qddot_max, str) else qddot_max,
        )

    # -- hand-eye ---------------------------------------------------------------------------

    @property
    def eMc(self) -> FloatArray:
        """4x4 camera pose in the end-effector frame (settable)."""
        return self._eMc

    @eMc.setter
    def eMc(self, value: ArrayLike) -> None:
        T = as_transform(value, "eMc")
        self._eMc = T
        self._cVe = twist_transform(inverse(T))

    @property
    def cVe(self) -> FloatArray:
        """6x6 twist transform from the end-effector frame to the camera frame."""
        return self._cVe

    # -- kinematics -------------------------------------------------------------------------

    def check_q(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``q`` as an (n,) array; raise if its shape is wrong or it is outside the limits."""
        if check_limits:
            return self._limits.check(q)
        return as_vector(q, "q", self.n)

    @abc.abstractmethod
    def fkine_ee(self, q: FloatArray) -> FloatArray:
        """Return ``bMe`` (4x4), the end-effector pose in the base frame, for a validated q."""

    @abc.abstractmethod
    def jacobe(self, q: FloatArray) -> FloatArray:
        """Return ``eJe`` (6, n): end-effector twist in the end-effector frame, for a validated q."""

    def fkine(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``bMc`` (4x4), the camera pose in the base frame.

        Args:
            q: (n,) joint positions (m or rad).
            check_limits: Raise :class:`JointLimitError` if ``q`` is outside the limits.
        """
        qa = self.check_q(q, check_limits=check_limits)
        return self.fkine_ee(qa) @ self._eMc

    def jacobian(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``J(q) = cVe · eJe(q)`` (6, n), with ``v_c = J(q) q̇`` in the camera frame."""
        qa = self.check_q(q, check_limits=check_limits)
        return self._cVe @ self.jacobe(qa)

    def kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """Return ``(fkine(q), jacobian(q))`` with one validation of ``q`` (the control hot path).

        Returns:
            ``bMc`` (4x4), the camera pose in the base frame, and ``J(q)`` (6, n).
        """
        qa = self.check_q(q, check_limits=check_limits)
        return self.fkine_ee(qa) @ self._eMc, self._cVe @ self.jacobe(qa)

    def ikine(
        self,
        bMc: ArrayLike,
        q0: ArrayLike | None = None,
        *,
        tol: float = 1e-10,
        max_iterations: int = 500,
    ) -> FloatArray:
        """Find q with ``fkine(q) ≈ bMc`` by damped least squares, staying within the limits.

        Args:
            bMc: 4x4 desired camera pose in the base frame.
            q0: (n,) initial guess (default: mid-range).
            tol: Convergence threshold on the pose error twist norm.
            max_iterations: Iteration cap.

        Raises:
            JointLimitError: no configuration within the limits reaches the pose.
        """
        target = as_transform(bMc, "bMc")
        lim = self._limits
        q = lim.center.copy() if q0 is None else as_vector(q0, "q0", self.n).copy()
        q = np.clip(q, lim.q_min, lim.q_max)
        err = np.inf
        for _ in range(max_iterations):
            cur = self.fkine(q, check_limits=False)
            xi = log_transform(inverse(cur) @ target)  # camera-frame twist to the target
            err = float(np.linalg.norm(xi))
            if err < tol:
                return q
            J = self.jacobian(q, check_limits=False)
            mu = 1e-6 + 1e-3 * err
            dq = J.T @ np.linalg.solve(J @ J.T + mu * np.eye(6), xi)
            q = np.clip(q + dq, lim.q_min, lim.q_max)
        raise JointLimitError(
            f"ikine: no configuration within the joint limits of {self.name!r} reaches the pose "
            f"(residual twist norm {err:.3g} after {max_iterations} iterations); "
            "move the pose or give a better q0"
        )

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r} n={self.n}>"
