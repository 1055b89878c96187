"""A robot read from a URDF file, loaded by Pinocchio (extra ``redservo[urdf]``), run compiled.

:class:`URDFRobot` turns the chain of a URDF file from ``base_link`` down to
``camera_link`` into a :class:`~redservo.robots.Robot`: ``fkine_ee(q)`` is the
pose ``bMe`` of ``camera_link`` in the ``base_link`` frame and ``jacobe(q)`` its
6 x n Jacobian ``eJe`` in the ``camera_link`` frame (Pinocchio's ``LOCAL``
reference frame: ``(v, ω)``, ``v`` the velocity of the link origin), so that with
the optional ``eMc`` (default identity) ``fkine(q) = bMe · eMc`` and
``jacobian(q) = cVe · eJe`` as for every model.

Joints (``q`` in chain order, base to camera):

* ``revolute`` (rad) and ``prismatic`` (m) joints keep the file's ``<limit lower upper>``;
* a ``continuous`` joint is one angle (rad) with limits ``[-2π, 2π]``
  (:data:`~redservo.robots.urdf_parse.CONTINUOUS_LIMIT`): Pinocchio would store
  ``(cos θ, sin θ)``; we give it instead a range of two turns so that any
  orientation has a representative at least π from both limits, which the
  joint-limit avoidance then keeps clear of (narrow it with ``set_limits``);
* ``fixed`` joints are folded into the links; ``floating`` and ``planar`` joints
  on the chain are refused (:class:`ConfigurationError`).

Rate limits (:mod:`redservo.robots.urdf_limits`): velocities come from ``<limit
velocity>`` (rad/s or m/s) unless the caller gives ``qdot_max``; a servoed joint whose
file velocity is missing, not > 0, not finite or absurd (> 100 rad/s, > 10 m/s) is an
error naming the file and the joint, never a robot without velocity limits.
Accelerations come from redservo's ``<redservo:limit acceleration>`` element (the shipped
files carry the datasheet values) unless the caller gives ``qddot_max``; a file with none
gives ``qddot_max = None``. Efforts are ignored. Origins, axes and position limits are
checked (:mod:`redservo.robots.urdf_values`). What urdfdom prints while Pinocchio reads
the file is captured (:mod:`redservo.robots.urdf_stderr`): folded into our one error
message when Pinocchio rejects the file, one ``UserWarning`` when it still builds the
model (e.g. a malformed ``<visual>``, which the kinematics does not use).

Kinematics: the chain from ``base_link`` to ``camera_link`` is compiled once, at load,
into the fixed transforms and joint axes of a :class:`~redservo.robots.chain.ChainRobot`
(:mod:`redservo.robots.urdf_chain`: fixed and locked joints folded into the transforms),
so ``fkine``, ``jacobian`` and ``kinematics`` run the compiled chain kernels
(:mod:`redservo.kernels.chain`) and the compiled engines (the Controller's, the campaign
loop's) bind a URDF robot like a DH chain. Pinocchio stays the loader (it must accept the file) and the
oracle: :meth:`URDFRobot.pinocchio_kinematics` gives its ``(bMc, J)``, which the chain
agrees with to about 1e-15 (tests/test_chain.py checks ≤ 1e-12); :meth:`URDFRobot.link_poses`
(the viewer) also uses it. The reduced Pinocchio model (only the servoed joints) is built
once. A robot holds Pinocchio work data for those two methods: give each thread its own
copy (``copy.copy`` makes new data).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, UnknownNameError
from redservo.robots.chain import ChainRobot
from redservo.robots.urdf_chain import compile_chain
from redservo.robots.urdf_limits import RateLimit, rate_limits
from redservo.robots.urdf_parse import (
    CONTINUOUS_LIMIT,
    URDFJoint,
    URDFTree,
    chain,
    locked_values,
    pinocchio_xml,
    read_urdf,
)
from redservo.robots.urdf_stderr import captured_stderr, condense
from redservo.spatial import inverse

__all__ = ["URDFRobot", "shipped_urdf"]

SHIPPED_URDFS = ("panda", "ur5e")
"""Names accepted by :func:`shipped_urdf`."""

_PIN: Any = None  # the pinocchio module, imported on first use


def _pinocchio() -> Any:
    """Import Pinocchio once, or raise a :class:`ConfigurationError` naming the extra."""
    global _PIN
    if _PIN is None:
        try:
            import pinocchio
        except ImportError as exc:
            raise ConfigurationError(
                "URDFRobot needs Pinocchio (PyPI package 'pin'): pip install 'redservo[urdf]'"
            ) from exc
        _PIN = pinocchio
    return _PIN


def shipped_urdf(name: str) -> Path:
    """Return the path of a URDF file shipped with redservo: ``"panda"`` or ``"ur5e"``.

    Both carry a fixed ``camera_link`` (docs/robots.md)::

        robot = URDFRobot(shipped_urdf("ur5e"), camera_link="camera_link")

    Raises:
        UnknownNameError: unknown name (the message lists the shipped ones).
    """
    key = name.strip().lower() if isinstance(name, str) else name
    if key not in SHIPPED_URDFS:
        raise UnknownNameError(
            f"no shipped URDF {name!r}; shipped: {', '.join(SHIPPED_URDFS)}", argument="name"
        )
    return Path(__file__).with_name("data") / f"{key}.urdf"


def _chosen_joints(
    tree: URDFTree, movable: list[URDFJoint], joints: Sequence[str]
) -> list[URDFJoint]:
    """Return the joints named by ``joints``, checked against the chain's ``movable`` joints.

    Each name must be a joint of the file, movable, between ``base_link`` and
    ``camera_link``, listed once and in chain order (base to camera). Joint names carry no
    units.

    Raises:
        ConfigurationError: ``joints`` is a string, names a fixed or off-chain joint, or is
            not distinct and in chain order.
        UnknownNameError: a name is not a joint of the file.
    """
    names = [j.name for j in movable]
    if isinstance(joints, str):
        raise ConfigurationError(
            f"joints must be a sequence of joint names, got the string {joints!r}",
            argument="joints",
        )
    joints = list(joints)
    for name in joints:
        if name not in tree.joints:
            raise UnknownNameError(
                f"joints: {name!r} is not a joint of {tree.source}; the movable joints "
                f"from base_link to camera_link are: {', '.join(names)}",
                argument="joints",
            )
        if name not in names:
            raise ConfigurationError(
                f"joints: {name!r} ({tree.joints[name].kind}) is not a movable joint between "
                f"base_link and camera_link in {tree.source}; those are: {', '.join(names)}",
                argument="joints",
            )
    order = [n for n in names if n in joints]
    if order != joints:
        raise ConfigurationError(
            f"joints must be distinct and in chain order (base to camera_link), "
            f"got {joints}; in order: {order}",
            argument="joints",
        )
    return [j for j in movable if j.name in joints]


def _servo_joints(
    tree: URDFTree, path: list[URDFJoint], joints: Sequence[str] | None
) -> list[URDFJoint]:
    """Return the servoed joints: ``joints`` (checked) or every movable joint of ``path``."""
    movable = [j for j in path if j.movable]
    for j in movable:
        if j.kind in ("floating", "planar"):
            raise ConfigurationError(
                f"joint {j.name!r} of {tree.source} is {j.kind}; URDFRobot supports revolute, "
                "continuous and prismatic joints on the chain to camera_link",
                argument="path",
            )
    chosen = movable if joints is None else _chosen_joints(tree, movable, joints)
    if not chosen:
        raise ConfigurationError(
            f"no movable joint between base_link and camera_link in {tree.source}",
            argument="joints",
        )
    for j in chosen:
        if j.mimic:
            raise ConfigurationError(
                f"joint {j.name!r} of {tree.source} mimics another joint; leave it out of "
                "joints= (it is then locked)",
                argument="joints",
            )
        if j.kind != "continuous" and not (
            j.lower is not None and j.upper is not None and j.upper > j.lower
        ):
            raise ConfigurationError(
                f"joint {j.name!r} of {tree.source} needs <limit lower=... upper=...> with "
                f"upper > lower, got lower={j.lower}, upper={j.upper}",
                argument="path",
            )
    return chosen


def _position_limits(j: URDFJoint) -> tuple[float, float]:
    if j.kind == "continuous":
        return -CONTINUOUS_LIMIT, CONTINUOUS_LIMIT
    assert j.lower is not None and j.upper is not None  # checked by _servo_joints
    return j.lower, j.upper


class URDFRobot(ChainRobot):
    """A serial chain of a URDF file, from ``base_link`` down to the camera, run compiled.

    Example::

        from redservo.robots import URDFRobot, shipped_urdf
        robot = URDFRobot(shipped_urdf("panda"), camera_link="camera_link")
        bMc, J = robot.kinematics(q)  # 4x4 camera pose, 6 x 7 camera Jacobian

    Args:
        path: The ``.urdf`` file.
        camera_link: The link whose frame is the end-effector frame ``e`` (for an
            eye-in-hand camera, usually the camera's optical frame: z along the optical
            axis, x to the right of the image).
        joints: The joints the servo drives (``q`` follows this order, which must be
            the chain order); default: every movable joint from ``base_link`` to
            ``camera_link``. Every other movable joint of the file is locked.
        eMc: 4x4 camera pose in the ``camera_link`` frame (default identity).
        base_link: The base frame ``b`` (default: the root link of the file).
        locked_q: Values of locked joints (m or rad), by name. A locked joint not listed
            sits at 0, or at mid-range if 0 is outside its limits (floating and planar
            joints off the chain sit at Pinocchio's neutral configuration).
        qdot_max: Joint velocity limits (rad/s or m/s): None (default: the file's), a
            scalar or (n,) (the file's are ignored), or ``{joint name: value}`` (replaces
            the file's for those joints only).
        qddot_max: Joint acceleration limits (rad/s² or m/s²), the same forms: None
            (default) takes the file's ``<redservo:limit acceleration>``, or none if the
            file has none.
        name: Model name (default: the ``<robot name>`` of the file).

    Raises:
        ConfigurationError: the extra is missing; the file is missing or malformed (an
            origin, axis or position limit out of bounds included); ``camera_link`` is not
            downstream of ``base_link``; a chain joint is floating or planar; ``joints``
            is not a chain-order subset of the chain; a servoed joint's velocity (or
            acceleration) limit is missing or invalid in the file and not given.
        UnknownNameError: unknown ``camera_link``, ``base_link``, or a name in
            ``joints``, ``locked_q``, ``qdot_max`` or ``qddot_max`` (the message lists
            the allowed names).
        JointLimitError: a ``locked_q`` value is outside its joint's limits.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        camera_link: str,
        joints: Sequence[str] | None = None,
        eMc: ArrayLike | None = None,
        base_link: str | None = None,
        locked_q: Mapping[str, float] | None = None,
        qdot_max: RateLimit = None,
        qddot_max: RateLimit = None,
        name: str | None = None,
    ) -> None:
        pin = _pinocchio()
        tree = read_urdf(path)
        base = tree.root if base_link is None else base_link
        path_joints = chain(tree, base, camera_link)
        servo = _servo_joints(tree, path_joints, joints)
        locked = locked_values(tree, servo, locked_q)
        limits = np.array([_position_limits(j) for j in servo])
        qdot, qddot = rate_limits(tree.source, servo, qdot_max, qddot_max)
        origins, axes, types, end = compile_chain(tree.source, path_joints, servo, locked)
        super().__init__(
            origins,
            axes,
            types,
            end,
            name=name or tree.name or Path(path).stem,
            joint_names=[j.name for j in servo],
            q_min=limits[:, 0],
            q_max=limits[:, 1],
            eMc=eMc,
            qdot_max=qdot,
            qddot_max=qddot,
        )
        self.path = Path(path)
        self.base_link = base
        self.camera_link = camera_link
        self.locked_q: dict[str, float] = locked
        self.urdf_joint_types: tuple[str, ...] = tuple(j.kind for j in servo)
        self.link_names: tuple[str, ...] = tree.links
        self.chain_links: tuple[str, ...] = (base, *(j.child for j in path_joints))
        """The links from ``base_link`` to ``camera_link``, in order (what carries the camera)."""
        self._model = self._build_model(pin, tree, locked)
        self._setup()

    def _build_model(self, pin: Any, tree: URDFTree, locked: dict[str, float]) -> Any:
        """Build the Pinocchio model of the file and reduce it to the servoed joints."""
        xml = pinocchio_xml(tree)
        failure: Exception | None = None
        with captured_stderr() as printed:  # urdfdom prints its complaints on fd 2
            try:
                full = pin.buildModelFromXML(xml)
            except Exception as exc:  # Pinocchio raises RuntimeError/ValueError
                failure = exc
        said = condense(printed[0])
        if failure is not None:
            parser = f" (urdfdom: {said})" if said else ""
            raise ConfigurationError(
                f"Pinocchio cannot build a model from {tree.source}: {failure}{parser}",
                argument="path",
            ) from None
        if said:  # e.g. a malformed <visual>, which the kinematics does not use
            warnings.warn(
                f"URDF {tree.source} loaded, but its parser said: {said}", UserWarning, stacklevel=3
            )
        q_ref = pin.neutral(full)
        to_lock = []
        for jid in range(1, full.njoints):
            jname = full.names[jid]
            if jname in self.joint_names:
                continue
            to_lock.append(jid)
            if jname in locked and full.joints[jid].nq == 1:
                q_ref[full.joints[jid].idx_q] = locked[jname]
        return pin.buildReducedModel(full, to_lock, q_ref) if to_lock else full

    def _setup(self) -> None:
        """Create the work data and the constant indices (also after unpickling)."""
        pin = _pinocchio()
        model = self._model
        body = pin.FrameType.BODY
        self._data = model.createData()
        self._viewer_data = model.createData()
        self._chain_cache = None
        self._local = pin.ReferenceFrame.LOCAL
        self._camera_frame = model.getFrameId(self.camera_link, body)
        self._link_frames = {link: model.getFrameId(link, body) for link in self.link_names}
        idx = [model.joints[model.getJointId(jn)].idx_q for jn in self.joint_names]
        if model.nq != self.n or sorted(idx) != list(range(self.n)):
            raise ConfigurationError(  # pragma: no cover - guarded by the checks above
                f"internal: reduced Pinocchio model of {self.path} has nq={model.nq}, "
                f"expected {self.n} one-variable joints"
            )
        self._idx = None if idx == list(range(self.n)) else np.array(idx)
        self._q_order = None if self._idx is None else np.argsort(self._idx)
        pin.framesForwardKinematics(model, self._viewer_data, pin.neutral(model))
        oMb = self._viewer_data.oMf[self._link_frames[self.base_link]].homogeneous
        self._bMo = None if np.array_equal(oMb, np.eye(4)) else inverse(oMb)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        for key in ("_data", "_viewer_data", "_chain_cache", "_local"):
            state.pop(key, None)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._setup()

    # -- the oracle -----------------------------------------------------------------------------

    def pinocchio_kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """Return ``(bMc, J)`` computed by Pinocchio: the reference of :meth:`kinematics`.

        The same quantities as :meth:`kinematics` (camera pose, 4x4 in m; ``J = cVe eJe``,
        6 x n) from the reduced Pinocchio model: one ``computeJointJacobians``, one
        ``updateFramePlacement`` and one ``getFrameJacobian`` (``LOCAL`` frame). The compiled
        chain agrees with it to rounding (tests/test_chain.py); it is several times slower
        (docs/speed.md).
        """
        qa = self.check_q(q, check_limits=check_limits)
        pin, model, data, frame = _pinocchio(), self._model, self._data, self._camera_frame
        qp = qa if self._q_order is None else qa[self._q_order]
        pin.computeJointJacobians(model, data, qp)  # also the joint placements data.oMi
        bMe = pin.updateFramePlacement(model, data, frame).homogeneous
        J = pin.getFrameJacobian(model, data, frame, self._local)
        if self._bMo is not None:
            bMe = self._bMo @ bMe
        if self._idx is not None:
            J = J[:, self._idx]
        return bMe @ self._eMc, self._cVe @ J

    # -- viewer ---------------------------------------------------------------------------------

    def link_poses(self, q: ArrayLike, *, check_limits: bool = True) -> dict[str, FloatArray]:
        """Return the pose (4x4, m) of every link of the file in the ``base_link`` frame.

        Args:
            q: (n,) joint positions (m or rad); locked joints sit at :attr:`locked_q`.
            check_limits: Raise :class:`JointLimitError` if ``q`` is outside the limits.

        Returns:
            ``{link name: bMl}`` for every name of :attr:`link_names`, in file order.
        """
        qa = self.check_q(q, check_limits=check_limits)
        pin, data = _pinocchio(), self._viewer_data
        pin.framesForwardKinematics(
            self._model, data, qa if self._q_order is None else qa[self._q_order]
        )
        bMo = np.eye(4) if self._bMo is None else self._bMo
        return {link: bMo @ data.oMf[fid].homogeneous for link, fid in self._link_frames.items()}
