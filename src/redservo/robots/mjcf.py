"""A robot read from an MJCF file (MuJoCo's format, e.g. MuJoCo Menagerie), run compiled.

:class:`MJCFRobot` turns the bodies of an MJCF file from a ``base`` body down to a ``tip``
(a site, a ``<camera>``, or a body) into a :class:`~redservo.robots.Robot`: ``fkine_ee(q)`` is the pose
``bMe`` of the tip in the base body's frame and ``jacobe(q)`` its 6 x n Jacobian ``eJe``
in the tip frame (``(v, ω)``, ``v`` the velocity of the tip's origin), so that with the
optional ``eMc`` (the camera in the tip frame, default identity: the tip frame *is* the
camera frame, z forward along the optical axis, x to the right of the image, y down; a
MuJoCo ``<camera>`` looks along its −z with y up, so a camera tip is that frame turned by π
about x) ``fkine(q) = bMe · eMc`` and ``jacobian(q) = cVe · eJe`` as for every model.

Joints (``q`` in chain order, base to tip, in MuJoCo's ``qpos`` units):

* ``hinge`` (rad) and ``slide`` (m) joints keep the file's ``range``; an unlimited hinge
  gets ``[-2π, 2π]`` as a URDF continuous joint does; an unlimited slide, a ``ball`` or a
  ``free`` joint on the chain is refused;
* joints off the chain (or left out of ``joints``) are locked at ``locked_q`` (default 0,
  or mid-range when 0 is outside their range).

Rate limits: MJCF gives none. Velocities are the caller's ``qdot_max`` (a scenario's
``robot.qdot_max``), else :data:`DEFAULT_QDOT_MAX` (1 rad/s, 0.25 m/s: a cautious
default under every arm's datasheet, stated in docs/robots.md), never a robot without
velocity limits; accelerations are ``qddot_max`` or none.

Kinematics: the chain is compiled once, at load, into the fixed transforms and joint axes
of a :class:`~redservo.robots.chain.ChainRobot` (:mod:`redservo.robots.mjcf_chain`), so
``fkine``/``jacobian``/``kinematics`` run the compiled chain kernels and the compiled loop
binds it like a URDF robot. MuJoCo stays the loader and the oracle:
:meth:`MJCFRobot.mujoco_kinematics` (``mj_kinematics`` and ``mj_jacSite``/``mj_jacBody``)
agrees with the chain to rounding (tests/test_mjcf_robot.py). Collision geometry:
:mod:`redservo.robots.mjcf_collision`. Units: metres, radians, seconds.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, JointLimitError, UnknownNameError
from redservo.robots.chain import ChainRobot
from redservo.robots.mjcf_chain import (
    FLIP,
    chain_path,
    compile_mjcf_chain,
    load_model,
    names_of,
    tip_frame,
)
from redservo.robots.mjcf_collision import MJCFCollision
from redservo.spatial import inverse

__all__ = ["DEFAULT_QDOT_MAX", "MJCFRobot", "shipped_mjcf"]

DEFAULT_QDOT_MAX: Final = {"revolute": 1.0, "prismatic": 0.25}
"""Velocity limit (rad/s, m/s) of a joint whose ``qdot_max`` is not given (module docstring)."""
SHIPPED_MJCFS: Final = {
    "panda": "franka_emika_panda/panda.xml",
    "ur5e": "universal_robots_ur5e/ur5e.xml",
}
"""The trimmed Menagerie models shipped with redservo (robots/data/menagerie)."""
_FULL_TURNS: Final = 2.0 * np.pi
_HINGE, _SLIDE = 3, 2  # mjJNT_HINGE, mjJNT_SLIDE


def shipped_mjcf(name: str) -> Path:
    """The path of a shipped trimmed Menagerie MJCF: ``"panda"`` or ``"ur5e"`` (site ``camera``)."""
    key = name.strip().lower() if isinstance(name, str) else name
    if key not in SHIPPED_MJCFS:
        raise UnknownNameError(
            f"no shipped MJCF {name!r}; shipped: {', '.join(SHIPPED_MJCFS)}", argument="name"
        )
    return Path(__file__).with_name("data") / "menagerie" / SHIPPED_MJCFS[key]


def _default_base(model: Any, tip_body: int) -> int:
    """The top body above the tip (a fixed base), or the world if that body has a joint."""
    top = tip_body
    while int(model.body_parentid[top]) != 0:
        top = int(model.body_parentid[top])
    return top if int(model.body_jntnum[top]) == 0 else 0


def _servo(model: Any, path: Sequence[int], joints: Sequence[str] | None, source: str) -> list[int]:
    """The servoed joint ids: ``joints`` (chain order) or every joint of the path."""
    on_path = [
        j
        for b in path
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
    ]
    names = names_of(model, "joint")
    for j in on_path:
        if int(model.jnt_type[j]) not in (_HINGE, _SLIDE):
            raise ConfigurationError(
                f"joint {names[j]!r} of {source} is a ball or free joint; MJCFRobot supports "
                "hinge and slide joints between base and tip",
                argument="tip",
            )
    if joints is None:
        chosen = on_path
    else:
        if isinstance(joints, str):
            raise ConfigurationError(
                f"joints must be a sequence of joint names, got the string {joints!r}",
                argument="joints",
            )
        path_names = [names[j] for j in on_path]
        for name in joints:
            if name not in path_names:
                raise UnknownNameError(
                    f"joints: {name!r} is not a joint between base and tip in {source}; "
                    f"those are: {', '.join(path_names)}",
                    argument="joints",
                )
        chosen = [j for j in on_path if names[j] in joints]
        if [names[j] for j in chosen] != list(joints):
            raise ConfigurationError(
                f"joints must be distinct and in chain order (base to tip), got {list(joints)}",
                argument="joints",
            )
    if not chosen:
        raise ConfigurationError(f"no joint between base and tip in {source}", argument="tip")
    return chosen


def _limits(model: Any, j: int, source: str) -> tuple[float, float]:
    name = model.joint(j).name
    if bool(model.jnt_limited[j]):
        lo, hi = (float(v) for v in model.jnt_range[j])
        if lo < hi:
            return lo, hi
        raise ConfigurationError(
            f"joint {name!r} of {source}: range must have lower < upper, got {lo} {hi}",
            argument="path",
        )
    if int(model.jnt_type[j]) == _SLIDE:
        raise ConfigurationError(
            f"joint {name!r} of {source}: a slide joint needs a range (m)", argument="path"
        )
    return -_FULL_TURNS, _FULL_TURNS


def _locked(
    model: Any, servo: Sequence[int], given: Mapping[str, float] | None
) -> dict[int, float]:
    """The value (m or rad) of every hinge or slide joint not servoed: ``given`` or 0
    (mid-range if 0 is outside its range). Ball and free joints stay at MuJoCo's ``qpos0``."""
    names = names_of(model, "joint")
    free = [
        j
        for j in range(model.njnt)
        if j not in servo and int(model.jnt_type[j]) in (_HINGE, _SLIDE)
    ]
    for key in given or {}:
        if key not in [names[j] for j in free]:
            raise UnknownNameError(
                f"locked_q: {key!r} is not a locked hinge or slide joint; those are: "
                f"{', '.join(names[j] for j in free) or '(none)'}",
                argument="locked_q",
            )
    out = {}
    for j in free:
        lo, hi = model.jnt_range[j] if model.jnt_limited[j] else (-np.inf, np.inf)
        value = float((given or {}).get(names[j], 0.0 if lo <= 0.0 <= hi else 0.5 * (lo + hi)))
        if not (np.isfinite(value) and lo <= value <= hi):
            raise JointLimitError(
                f"locked_q: {names[j]!r} = {value} is outside its range [{lo}, {hi}]",
                argument="locked_q",
            )
        out[j] = value
    return out


def _rates(types: Sequence[str], names: Sequence[str], given: Any, default: bool) -> Any:
    """Per-joint rates from a scalar, (n,) or ``{name: value}`` (defaults for the others)."""
    if isinstance(given, Mapping):
        for key in given:
            if key not in names:
                raise UnknownNameError(
                    f"{key!r} is not a servoed joint; those are: {', '.join(names)}",
                    argument="qdot_max" if default else "qddot_max",
                )
        if not default and len(given) != len(names):
            raise ConfigurationError(
                "qddot_max as a mapping must name every servoed joint", argument="qddot_max"
            )
        return np.array([float(given.get(n, DEFAULT_QDOT_MAX[t])) for n, t in zip(names, types)])
    if given is None and default:
        return np.array([DEFAULT_QDOT_MAX[t] for t in types])
    return given


def _pose(xmat: FloatArray, xpos: FloatArray) -> FloatArray:
    """The 4x4 pose of MuJoCo's flat ``xmat`` (9,) and ``xpos`` (3,), world frame (m)."""
    M = np.eye(4)
    M[:3, :3] = np.reshape(xmat, (3, 3))
    M[:3, 3] = xpos
    return M


def _tip_id(model: Any, tip: str) -> tuple[str, int]:
    """``("site" | "camera" | "body", id)`` of the tip (the order of :func:`tip_frame`)."""
    for kind, count in (("site", model.nsite), ("camera", model.ncam), ("body", model.nbody)):
        names = [getattr(model, kind)(i).name for i in range(count)]
        if tip in names:
            return kind, names.index(tip)
    raise AssertionError(tip)  # pragma: no cover - tip_frame raised first


class MJCFRobot(ChainRobot):
    """A serial chain of an MJCF file, from ``base`` down to ``tip``, run compiled.

    Example::

        from redservo.robots.mjcf import MJCFRobot, shipped_mjcf
        robot = MJCFRobot(shipped_mjcf("ur5e"), tip="camera")
        bMc, J = robot.kinematics(q)  # 4x4 camera pose (m), 6 x 6 camera Jacobian

    Args:
        path: The MJCF (``.xml``) file; its assets must lie inside its folder.
        tip: A site (z along the optical axis), a ``<camera>`` (turned by π about x into
            ours) or a body: the end-effector frame ``e``.
        base: The base body ``b`` (default: the top body of the tree holding ``tip``, or
            ``"world"`` when that body has a joint).
        joints: The servoed joints (chain order; default: every joint from base to tip).
        eMc: 4x4 camera pose in the tip frame (default identity).
        locked_q: Values (m or rad) of the other joints, by name.
        qdot_max: Velocity limits (rad/s or m/s): scalar, (n,) or ``{joint: value}``;
            default :data:`DEFAULT_QDOT_MAX`.
        qddot_max: Acceleration limits (rad/s² or m/s²): scalar, (n,) or a mapping naming
            every joint; default none.
        name: Model name (default: the MJCF's ``model``).

    Raises:
        ConfigurationError: the file is missing or MuJoCo rejects it; tip is not below
            base; a ball/free joint or an unlimited slide on the chain; bad ``joints``.
        GeometryError: an asset outside the model's folder.
        UnknownNameError: unknown ``tip``, ``base``, joint names (the message lists them).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        tip: str,
        base: str | None = None,
        joints: Sequence[str] | None = None,
        eMc: ArrayLike | None = None,
        locked_q: Mapping[str, float] | None = None,
        qdot_max: Any = None,
        qddot_max: Any = None,
        name: str | None = None,
    ) -> None:
        model = load_model(path)
        source = str(path)
        tip_body, end = tip_frame(model, tip, source)
        bodies = names_of(model, "body")
        if base is None:
            base = bodies[_default_base(model, tip_body)]
        if base not in bodies:
            raise UnknownNameError(
                f"base: {base!r} is not a body of {source}; bodies: {', '.join(bodies)}",
                argument="base",
            )
        base_id = bodies.index(base)
        path_ids = chain_path(model, base_id, tip_body, source)
        servo = _servo(model, path_ids, joints, source)
        locked = _locked(model, servo, locked_q)
        origins, axes, types = compile_mjcf_chain(model, path_ids, servo, locked, end)
        joint_names = [model.joint(j).name for j in servo]
        limits = np.array([_limits(model, j, source) for j in servo])
        super().__init__(
            origins[:-1],
            axes,
            types,  # type: ignore[arg-type]
            origins[-1],
            name=name or model.names[: model.names.index(b"\0")].decode() or Path(path).stem,
            joint_names=joint_names,
            q_min=limits[:, 0],
            q_max=limits[:, 1],
            eMc=eMc,
            qdot_max=_rates(types, joint_names, qdot_max, True),
            qddot_max=_rates(types, joint_names, qddot_max, False),
        )
        self.path = Path(path)
        self.base = base
        self.tip = tip
        self.locked_q = {model.joint(j).name: v for j, v in locked.items()}
        self._servo_ids = tuple(servo)
        self._base_id, self._tip_body = base_id, tip_body
        self._tip_id = _tip_id(model, tip)
        self._attach(model)

    def _attach(self, model: Any) -> None:
        """Work data and the collision geometry (also after unpickling)."""
        import mujoco

        self._model = model
        self._data = mujoco.MjData(model)
        for j, v in self.locked_names_ids().items():
            self._data.qpos[model.jnt_qposadr[j]] = v
        self._collision = MJCFCollision(model, self._base_id, self._servo_ids)

    def locked_names_ids(self) -> dict[int, float]:
        """The locked joints' values (m or rad) by MuJoCo joint id."""
        names = names_of(self._model, "joint")
        return {names.index(k): v for k, v in self.locked_q.items()}

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        for key in ("_model", "_data", "_collision", "_chain_cache"):
            state.pop(key, None)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._chain_cache = None
        self._attach(load_model(self.path))

    def _pose(self, q: FloatArray) -> None:
        """Run ``mj_kinematics``, ``mj_comPos`` and ``mj_camlight`` at ``q`` (locked joints at
        their values)."""
        import mujoco

        m, d = self._model, self._data
        for j, v in zip(self._servo_ids, q):
            d.qpos[m.jnt_qposadr[j]] = v
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_camlight(m, d)  # the cameras' cam_xpos, cam_xmat

    def _world_pose(self, body: int) -> FloatArray:
        return _pose(self._data.xmat[body], self._data.xpos[body])

    def mujoco_kinematics(
        self, q: ArrayLike, *, check_limits: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """``(bMc, J)`` computed by MuJoCo, the reference of :meth:`kinematics` (4x4 in m;
        ``J = cVe eJe``, 6 x n): the tip's pose from ``mj_kinematics`` (``site_xpos``/``xmat``,
        ``cam_xpos``/``xmat`` turned by :data:`~redservo.robots.mjcf_chain.FLIP`, or the body's)
        and its Jacobian from ``mj_jacSite`` (a site) or ``mj_jac`` at its origin."""
        import mujoco

        qa = self.check_q(q, check_limits=check_limits)
        self._pose(qa)
        m, d = self._model, self._data
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        kind, k = self._tip_id
        if kind == "site":  # MuJoCo's own pose and Jacobian of the site
            wMe = _pose(d.site_xmat[k], d.site_xpos[k])
            mujoco.mj_jacSite(m, d, jacp, jacr, k)
        else:  # a camera (turned into ours) or a body: the Jacobian at its origin
            wMe = self._world_pose(self._tip_body)
            if kind == "camera":
                wMe = _pose(d.cam_xmat[k], d.cam_xpos[k]) @ FLIP
            mujoco.mj_jac(m, d, jacp, jacr, wMe[:3, 3], self._tip_body)
        cols = [int(m.jnt_dofadr[j]) for j in self._servo_ids]
        Rt = wMe[:3, :3].T
        eJe = np.vstack([Rt @ jacp[:, cols], Rt @ jacr[:, cols]])
        bMe = inverse(self._world_pose(self._base_id)) @ wMe
        return bMe @ self._eMc, self._cVe @ eJe

    def link_poses(self, q: ArrayLike, *, check_limits: bool = True) -> dict[str, FloatArray]:
        """The pose (4x4, m) in the base frame of every body under ``base`` (base first)."""
        qa = self.check_q(q, check_limits=check_limits)
        self._pose(qa)
        bMw = inverse(self._world_pose(self._base_id))
        return {
            self._model.body(b).name: bMw @ self._world_pose(b) for b in self._collision.subtree
        }

    def collision_capsules(self, radii: Mapping[str, float] | None = None) -> tuple[Any, ...]:
        """One capsule per body with collision geoms (:mod:`redservo.robots.mjcf_collision`)."""
        return self._collision.capsules(radii)

    def collision_points(self, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """The capsules' end points (2 per body, base frame, m) and their (3, n) Jacobians."""
        qa = self.check_q(q, check_limits=False)
        self._pose(qa)
        return self._collision.points(self._data)
