"""An MJCF model of any redservo robot, built from our own kinematics (exact by construction).

**Kinematics.** A serial arm is its product of exponentials: with ``ξ_j`` the twist of
joint j at the reference configuration ``q = 0`` (axis ``z_j`` through a point ``p_j``,
or a sliding direction, in the base frame)::

    bMc(q) = exp(ξ_0 q_0) ⋯ exp(ξ_{n-1} q_{n-1}) bMc(0)

The twists are read from our own model (``robot.fkine(0)`` and ``robot.jacobian(0)``: the
angular column of a revolute joint is ``z_j``, its linear one ``v_j = z_j × (p_c − p_j)``,
so ``p_c + z_j × v_j`` is a point of the axis), and the MJCF nests one body per joint,
every body frame at the base frame when ``q = 0``, joint j at ``p_j`` along ``z_j``. MuJoCo
then computes exactly the same chain: DH robots (Panda, Afma6, the humanoid), URDF robots
and :class:`~redservo.robots.chain.ChainRobot` alike, with no mesh or URDF parsing. A
coupled joint is a linear map ``qpos = T q`` (the Afma6's ``C' = C − g B``,
:func:`joint_map`); the camera pose then agrees with ``robot.fkine`` to ~1e-15 (the test
asks for 1e-9 m / rad on random ``q``).

**Geometry and inertia** (a choice: our models have no meshes): each moving body carries a
capsule of radius ``link_radius`` (default 0.05 m) from the point of its joint axis closest
to the previous one to the next such point, a 0.2 m box for a slide (a gantry carriage),
and density 2000 kg/m³ (the shipped Panda then weighs about 18 kg, close to the real arm's
18 kg). Rotor inertia: ``armature`` 0.1 kg·m² (revolute) / 1 kg (prismatic), MuJoCo
Menagerie's value for the Panda. The robot's geoms collide with nothing.

**Camera.** MuJoCo's camera looks along its −z with y up; ours along +z with y down: the
MJCF camera is ours turned by π about x. Its intrinsics are ours (``focalpixel``,
``principalpixel``, ``resolution``), so a rendered point lands where
:class:`~redservo.camera.Camera` projects it (pixel centres at ``i + 0.5``). The camera is on
the last link at ``bMc(0)`` (eye-in-hand), or (eye-to-hand, :func:`robot_bodies`' ``effector``)
fixed in the world by :func:`camera_xml`, the last link then carrying a site at the end
effector and the target bodies.

Units: metres, radians, kilograms, seconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.robots.base import Robot

__all__ = ["Chain", "camera_xml", "chain_of", "joint_map", "robot_bodies", "xml_pose"]

FLIP = np.diag([1.0, -1.0, -1.0])
"""Our camera frame (z forward, y down) → MuJoCo's (−z forward, y up): ``R_mj = R · FLIP``."""


@dataclass(frozen=True)
class Chain:
    """A serial arm as MuJoCo nests it (module docstring), in the base frame at ``qpos = 0``."""

    axes: FloatArray
    """(n, 3) unit joint axes (rotation axis or sliding direction)."""
    points: FloatArray
    """(n, 3) a point of each revolute joint's axis (m); unused for a slide."""
    slide: tuple[bool, ...]
    """Per joint, True for a prismatic joint."""
    bMc0: FloatArray
    """4x4 camera pose at ``qpos = 0`` (m)."""
    T: FloatArray
    """(n, n) ``qpos = T q``: MuJoCo's joint coordinates from ours (identity unless coupled)."""


def joint_map(robot: Robot) -> FloatArray:
    """``T`` with ``qpos = T q`` (identity, except the Afma6's coupling ``C' = C − g B``)."""
    T = np.eye(robot.n)
    from redservo.robots.afma6 import COUPLING, Afma6

    if isinstance(robot, Afma6):
        T[5, 4] = -COUPLING
    return T


def chain_of(robot: Robot) -> Chain:
    """Read the product-of-exponentials chain of ``robot`` at ``q = 0`` (module docstring).

    Raises:
        ConfigurationError: a joint's twist is not a unit rotation or translation (the robot
            is not a serial chain of independent joints in MuJoCo's coordinates).
    """
    T = joint_map(robot)
    zero = np.zeros(robot.n)
    bMc0 = robot.fkine(zero, check_limits=False)
    R, pc = bMc0[:3, :3], bMc0[:3, 3]
    Jc = robot.jacobian(zero, check_limits=False) @ np.linalg.inv(T)
    v, w = R @ Jc[:3], R @ Jc[3:]
    axes, points, slide = np.zeros((robot.n, 3)), np.zeros((robot.n, 3)), []
    for j, kind in enumerate(robot.joint_types):
        prismatic = kind == "prismatic"
        vec = v[:, j] if prismatic else w[:, j]
        other = w[:, j] if prismatic else np.zeros(3)
        if abs(np.linalg.norm(vec) - 1.0) > 1e-9 or np.linalg.norm(other) > 1e-9:
            raise ConfigurationError(
                f"{robot.name}: joint {j} ({robot.joint_names[j]}) is not an independent "
                f"{kind} joint at q = 0 (|axis| = {np.linalg.norm(vec):.6g}); MuJoCo cannot "
                "model this coupling",
                argument="robot",
            )
        axes[j] = vec
        points[j] = pc if prismatic else pc + np.cross(vec, v[:, j])
        slide.append(prismatic)
    return Chain(axes, points, tuple(slide), bMc0, T)


def _vec(x: FloatArray) -> str:
    return " ".join(f"{float(a):.17g}" for a in np.ravel(x))


def xml_pose(M: FloatArray) -> str:
    """``pos="…" xyaxes="…"`` attributes of a 4x4 pose (exact: no quaternion round trip)."""
    R = M[:3, :3]
    return f'pos="{_vec(M[:3, 3])}" xyaxes="{_vec(R[:, 0])} {_vec(R[:, 1])}"'


def _anchors(chain: Chain) -> list[FloatArray]:
    """Per joint, the point of its axis closest to the previous anchor (base origin first)."""
    prev = np.zeros(3)
    out = []
    for z, p, s in zip(chain.axes, chain.points, chain.slide):
        a = prev if s else p + z * float(z @ (prev - p))
        out.append(a)
        prev = a
    return out


def _short_of(a: FloatArray, b: FloatArray, d: float) -> FloatArray:
    """The point ``d`` (m) before ``b`` on the segment from ``a`` (``a`` if shorter)."""
    ab = b - a
    n = float(np.linalg.norm(ab))
    return np.asarray(a if n <= d else b - ab * (d / n))


def _link_geom(a: FloatArray, b: FloatArray, r: float, name: str) -> str:
    if np.linalg.norm(b - a) < 0.01:
        return f'<geom name="{name}" type="sphere" size="{r}" pos="{_vec(a)}" material="arm" group="1"/>'
    return (
        f'<geom name="{name}" type="capsule" size="{r}" fromto="{_vec(a)} {_vec(b)}" '
        'material="arm" group="1"/>'
    )


def camera_xml(bMc: FloatArray, camera: Camera) -> str:
    """The camera at ``bMc`` in its body's frame (ours turned by π about x), a site
    ``camera`` at our camera frame and a small housing behind the optical centre."""
    M = bMc.copy()
    M[:3, :3] = M[:3, :3] @ FLIP
    w, h = camera.width, camera.height
    # MuJoCo's principalpixel is (w/2 − u0, h/2 − v0): both axes reversed from ours (measured:
    # u0 = w/2 + 10 rendered with +10 put every point 20 px off; tests with off-centre u0, v0).
    dx, dy = w / 2.0 - camera.u0, h / 2.0 - camera.v0
    R, c = bMc[:3, :3], bMc[:3, 3]
    box = c - 0.03 * R[:, 2]  # the camera's housing, behind its optical centre
    return (
        f'<camera name="camera" {xml_pose(M)} resolution="{w} {h}" sensorsize="{w} {h}" '
        f'focalpixel="{camera.px:.17g} {camera.py:.17g}" principalpixel="{dx:.17g} {dy:.17g}"/>'
        f'<site name="camera" {xml_pose(bMc)} size="0.005"/>'
        f'<geom name="camera_housing" type="box" size="0.02 0.02 0.02" pos="{_vec(box)}" '
        f'xyaxes="{_vec(R[:, 0])} {_vec(R[:, 1])}" material="camera" group="1"/>'
    )


def robot_bodies(
    robot: Robot,
    chain: Chain,
    camera: Camera,
    *,
    link_radius: float = 0.04,
    effector: FloatArray | None = None,
    carried: str = "",
) -> tuple[str, list[str]]:
    """The nested bodies of the arm (MJCF text) and its joint names, base frame at identity.

    Every body has ``gravcomp="1"`` (gravity compensated, as a real arm's controller does).
    ``effector`` None: the camera is on the arm, at ``chain.bMc0``. Else (eye-to-hand) the
    arm has no camera; ``effector`` is ``bMe`` at ``qpos = 0`` (4x4): the last link ends
    there, carries a site ``effector`` at it and the bodies ``carried`` (MJCF text)."""
    anchors = _anchors(chain)
    R, c = chain.bMc0[:3, :3], chain.bMc0[:3, 3]
    # The last link stops behind the camera plane, so that the arm never fills the image
    # (eye-to-hand: its rounded end 5 mm short of the effector, where the objects are).
    if effector is None:
        tip = c - (0.03 + link_radius) * R[:, 2]
    else:
        tip = _short_of(anchors[-1], effector[:3, 3], link_radius + 0.005)
    ends = [*anchors[1:], tip]
    names = [f"j{j}" for j in range(robot.n)]
    xml, close = [], []
    for j in range(robot.n):
        z, p = chain.axes[j], chain.points[j]
        xml.append(f'<body name="link{j}" gravcomp="1">')
        # MuJoCo's hard stops at our limits (none on a coupled joint: its range depends on q).
        coupled = bool(np.count_nonzero(chain.T[j]) > 1)
        rng = "" if coupled else f'range="{robot.q_min[j]:.17g} {robot.q_max[j]:.17g}"'
        if chain.slide[j]:
            xml.append(
                f'<joint name="{names[j]}" type="slide" axis="{_vec(z)}" {rng} armature="1"/>'
            )
            xml.append(
                f'<geom name="g{j}" type="box" size="0.1 0.1 0.1" pos="{_vec(anchors[j])}" '
                'material="arm" group="1"/>'
            )
        else:
            xml.append(
                f'<joint name="{names[j]}" type="hinge" pos="{_vec(p)}" axis="{_vec(z)}" '
                f'{rng} armature="0.1"/>'
            )
            xml.append(_link_geom(anchors[j], ends[j], link_radius, f"g{j}"))
        close.append("</body>")
    if effector is None:
        xml.append(camera_xml(chain.bMc0, camera))
    else:
        xml.append(f'<site name="effector" {xml_pose(effector)} size="0.005"/>{carried}')
    return "".join(xml) + "".join(close), names
