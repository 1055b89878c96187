"""A serial robot given as a chain of fixed transforms and joint axes, run by compiled kernels.

:class:`ChainRobot` is the general form of a serial arm: before each joint a fixed rigid
transform ``F_i`` (4x4, m), then the joint's motion ``M_i(q_i)`` — a rotation of ``q_i``
rad about a unit axis through the origin of the joint's frame (revolute) or a translation
of ``q_i`` m along it (prismatic) — and after the last joint a fixed transform to the
end-effector frame ``e``::

    bMe(q) = F_0 M_0(q_0) F_1 M_1(q_1) ⋯ F_{n-1} M_{n-1}(q_{n-1}) F_end

This is how a URDF file describes a chain (``F_i`` is the joint's ``<origin>``, the axis
its ``<axis>``): :class:`~redservo.robots.URDFRobot` is a ``ChainRobot`` whose transforms
are compiled once from the file (:mod:`redservo.robots.urdf_chain`). ``eJe`` is the
geometric Jacobian of ``e`` in ``e`` (``(v, ω)``, ``v`` the velocity of the origin of
``e``), and ``fkine``/``jacobian``/``kinematics`` follow the Robot protocol
(:mod:`redservo.robots.base`). The kernels are those of :mod:`redservo.kernels.chain`;
:attr:`ChainRobot.chain` is their packed form (:class:`ChainPack`), which
:func:`redservo.campaign.looppack.robot_args` also binds.

Like :class:`~redservo.robots.DHRobot`, the last chain evaluation is cached on the exact
bytes of ``q``, and ``fkine(q)``/``jacobian(q)`` are bit for bit the two outputs of
``kinematics(q)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, ClassVar, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform, as_vector
from redservo.errors import ConfigurationError, ShapeError
from redservo.kernels import lazy
from redservo.robots.base import JointType, Robot
from redservo.robots.dh import check_q_named
from redservo.robots.pack import RobotKind, RobotPack

__all__ = ["ChainPack", "ChainRobot", "chain_pack"]

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import chain as _K
    from redservo.kernels import kinematics as _KIN
else:
    _K = lazy("chain")
    _KIN = lazy("kinematics")


class ChainPack(NamedTuple):
    """A chain as the kernels of :mod:`redservo.kernels.chain` take it (layout there)."""

    frames: FloatArray
    """(n+1, 3, 4) fixed transforms ``[R | t]`` (t in m): before each joint, then to ``e``."""
    joints: FloatArray
    """(n, 4) unit axis of each joint in its frame, then 1.0 (prismatic) or 0.0 (revolute)."""


def chain_pack(
    origins: Sequence[ArrayLike],
    axes: ArrayLike,
    joint_types: Sequence[JointType],
    end: ArrayLike | None = None,
) -> ChainPack:
    """Check and pack a chain (module docstring).

    Args:
        origins: n 4x4 rigid transforms ``F_i`` (m), each joint's frame in the frame before it.
        axes: (n, 3) joint axes in their own frames (normalised here; not zero).
        joint_types: ``"revolute"`` or ``"prismatic"`` per joint.
        end: 4x4 pose of the end-effector frame in the last joint's frame (default identity).

    Raises:
        ShapeError: a transform is not rigid, the axes are not (n, 3) finite, or an axis is zero.
        ConfigurationError: no joint, or an unknown joint type.
    """
    n = len(origins)
    if n == 0:
        raise ConfigurationError("a chain needs at least one joint", argument="origins")
    if len(joint_types) != n:
        raise ShapeError(f"{n} origins but {len(joint_types)} joint types", argument="joint_types")
    ax = np.asarray(axes, dtype=float)
    if ax.shape != (n, 3) or not np.all(np.isfinite(ax)):
        raise ShapeError(
            f"axes must be a finite ({n}, 3) array, got shape {ax.shape}", argument="axes"
        )
    norms = np.linalg.norm(ax, axis=1)
    if np.any(norms < 1e-12):
        i = int(np.argmin(norms))
        raise ShapeError(f"axes[{i}] is zero; a joint axis needs a direction", argument="axes")
    frames = np.empty((n + 1, 3, 4))
    for i, F in enumerate(origins):
        frames[i] = as_transform(F, f"origins[{i}]")[:3]
    frames[n] = np.eye(4)[:3] if end is None else as_transform(end, "end")[:3]
    joints = np.empty((n, 4))
    joints[:, :3] = ax / norms[:, None]
    for i, kind in enumerate(joint_types):
        if kind not in ("revolute", "prismatic"):
            raise ConfigurationError(
                f"joint_types[{i}] must be 'revolute' or 'prismatic', got {kind!r}",
                argument="joint_types",
            )
        joints[i, 3] = 1.0 if kind == "prismatic" else 0.0
    return ChainPack(np.ascontiguousarray(frames), np.ascontiguousarray(joints))


class ChainRobot(Robot):
    """A serial chain of fixed transforms and revolute/prismatic joints (module docstring).

    Example, a two-joint arm whose second joint slides along its tilted x axis::

        >>> import numpy as np
        >>> from redservo.robots.chain import ChainRobot
        >>> from redservo.spatial import make_transform
        >>> arm = ChainRobot(
        ...     [np.eye(4), make_transform(t=(0.3, 0.0, 0.1), rotvec=(0.0, 0.4, 0.0))],
        ...     axes=[(0, 0, 1), (1, 0, 0)],
        ...     joint_types=["revolute", "prismatic"],
        ...     q_min=[-2.0, 0.0],
        ...     q_max=[2.0, 0.2],
        ... )
        >>> arm.jacobian([0.3, 0.1]).shape
        (6, 2)

    Args:
        origins: n 4x4 transforms ``F_i`` (m): joint i's frame in the frame before it.
        axes: (n, 3) joint axes in their own frames (normalised).
        joint_types: ``"revolute"`` (q in rad) or ``"prismatic"`` (q in m) per joint.
        end: 4x4 pose of the end-effector frame in the last joint's frame (default identity).
        q_min: (n,) lower joint limits (m or rad).
        q_max: (n,) upper joint limits (m or rad).
        joint_names: One name per joint (default ``q0``, ``q1``, ...).
        eMc: 4x4 camera pose in the end-effector frame (default identity).
        qdot_max: Joint velocity limits (rad/s or m/s), scalar or (n,), or None.
        qddot_max: Joint acceleration limits (rad/s² or m/s²), scalar or (n,), or None.
        name: Model name.

    Raises:
        ShapeError, ConfigurationError: see :func:`chain_pack` and :class:`Robot`.
    """

    KIND: ClassVar[RobotKind] = RobotKind("chain")
    """Its compiled kinematics (:mod:`redservo.robots.pack`)."""

    def __init__(
        self,
        origins: Sequence[ArrayLike],
        axes: ArrayLike,
        joint_types: Sequence[JointType],
        end: ArrayLike | None = None,
        *,
        q_min: ArrayLike,
        q_max: ArrayLike,
        joint_names: Sequence[str] | None = None,
        eMc: ArrayLike | None = None,
        qdot_max: ArrayLike | None = None,
        qddot_max: ArrayLike | None = None,
        name: str = "chain",
    ) -> None:
        pack = chain_pack(origins, axes, joint_types, end)
        n = pack.joints.shape[0]
        super().__init__(
            name=name,
            joint_names=[f"q{i}" for i in range(n)] if joint_names is None else joint_names,
            joint_types=joint_types,
            q_min=as_vector(q_min, "q_min", n),
            q_max=as_vector(q_max, "q_max", n),
            eMc=eMc,
            qdot_max=qdot_max,
            qddot_max=qddot_max,
        )
        self._chain_pack = pack
        # (q bytes, (bMe, Z, P)) of the last evaluation; one attribute, swapped atomically.
        self._chain_cache: tuple[bytes, tuple[FloatArray, FloatArray, FloatArray]] | None = None

    @property
    def chain(self) -> ChainPack:
        """The packed chain the kernels take (:class:`ChainPack`; do not modify it)."""
        return self._chain_pack

    def check_q(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``q`` as an (n,) array; a limit violation names the joint."""
        return check_q_named(self, q, check_limits)

    def _forward(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(bMe, Z, P)`` for a validated q (:func:`redservo.kernels.chain.chain_forward`)."""
        key = q.tobytes()
        cache = self._chain_cache
        if cache is not None and cache[0] == key:
            return cache[1]
        pack = self._chain_pack
        out = _K.chain_forward(np.ascontiguousarray(q), pack.frames, pack.joints)
        self._chain_cache = (key, out)
        return out

    def fkine_ee(self, q: FloatArray) -> FloatArray:
        """Return ``bMe`` (4x4, m), the end-effector pose in the base frame, for a validated q."""
        return self._forward(q)[0].copy()

    def jacobe(self, q: FloatArray) -> FloatArray:
        """Return ``eJe`` (6, n): the end-effector twist ``(v, ω)`` in its own frame (m/s, rad/s
        per unit of q̇), for a validated q."""
        bMe, Z, P = self._forward(q)
        return np.asarray(_K.chain_jacobe(bMe, Z, P, self._chain_pack.joints))

    def fkine(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``bMc`` (4x4, m): the same kernel product as :meth:`kinematics`, bit for bit."""
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        return np.asarray(_KIN.matmul(self._forward(qa)[0], self._eMc))

    def jacobian(self, q: ArrayLike, *, check_limits: bool = True) -> FloatArray:
        """Return ``J(q) = cVe eJe`` (6, n): the same kernel product as :meth:`kinematics`."""
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        return np.asarray(_KIN.matmul(self._cVe, self.jacobe(qa)))

    def kernel_pack(self) -> RobotPack | None:
        """The chain as the compiled engine takes it (:mod:`redservo.robots.pack`)."""
        if type(self).kinematics is not ChainRobot.kinematics:
            return None
        pack = self._chain_pack
        return self.KIND.pack(self._eMc, self._cVe, table=pack.joints, frames=pack.frames)

    def kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """Return ``(fkine(q), jacobian(q))`` in one kernel call (the control hot path)."""
        qa = np.ascontiguousarray(self.check_q(q, check_limits=check_limits))
        pack = self._chain_pack
        bMc, J = _K.chain_kinematics(qa, pack.frames, pack.joints, self._eMc, self._cVe)
        return bMc, J
