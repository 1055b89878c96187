"""A MuJoCo arm: the model (robot + scene + light), its physics step and its camera image.

:class:`MujocoArm` owns one ``MjModel``/``MjData``. Control: one MuJoCo *velocity
actuator* per joint, force ``kv_j (q̇_cmd,j − q̇_j)`` (N·m or N), on an arm whose every
body is gravity-compensated (``gravcomp``, as a real arm's controller compensates
gravity), integrated by ``implicitfast`` at a fixed ``timestep`` (default 1 ms). The gain
is ``kv_j = (M_jj(q_ref) + armature_j) / tracking_time``: each joint alone, at the
reference posture, follows a step of its velocity command with the time constant
``tracking_time`` (default 0.02 s); coupling through the mass matrix and Coriolis forces,
and other postures, make the real tracking differ (what :attr:`MujocoArm.tracking` records).

:meth:`MujocoArm.step` holds a command for a duration (whole physics steps) and records the
peak and the RMS of ``|q̇ − q̇_cmd|`` per joint. :meth:`MujocoArm.render` draws the camera
image, lit by one shadow-casting spot light and MuJoCo's head light.

**Eye-to-hand.** Given an :class:`~redservo.robots.eye_to_hand.EyeToHandRobot`, the model
is its carrier arm with no camera on it, the camera fixed in the world at the wrapper's
``bMc`` (same intrinsics convention as the hand camera), and the scene's objects (whose
frame is then the end effector's: ``wMo = eMo``) bodies fixed to the last link at ``eMo``,
moved by the physics; :meth:`MujocoArm.camera_pose` is then the wrapper's ``eMc(q)``.

Units: metres, radians, seconds (joint velocities rad/s or m/s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray, as_vector
from redservo.camera import Camera
from redservo.collision.shapes import Obstacle
from redservo.errors import ConfigurationError
from redservo.physics._mj import require_mujoco
from redservo.physics.lens import LensWarp
from redservo.physics.mjcf import Chain, _vec, camera_xml, chain_of, robot_bodies, xml_pose
from redservo.physics.obstacles import obstacle_bodies, set_obstacle_poses
from redservo.physics.scenes import scene_bodies, set_poses
from redservo.robots.base import Robot
from redservo.robots.eye_to_hand import EyeToHandRobot
from redservo.scene import Scene, Static
from redservo.schema.simulator import MIN_TIMESTEP

__all__ = ["MujocoArm", "TrackingStats"]

_ASSETS = (
    "<asset>"
    '<texture name="sky" type="skybox" builtin="flat" rgb1="0.45 0.47 0.5" rgb2="0.45 0.47 0.5" '
    'width="16" height="16"/>'
    '<material name="arm" rgba="0.85 0.55 0.2 1" specular="0.3"/>'
    '<material name="camera" rgba="0.1 0.1 0.12 1"/>'
    '<material name="paper" rgba="0.93 0.93 0.9 1" specular="0.05" shininess="0.1"/>'
    '<material name="ink" rgba="0.04 0.04 0.05 1" specular="0" shininess="0"/>'
    '<material name="object" rgba="0.6 0.6 0.62 1" specular="0.2"/>'
    "</asset>"
)

_EYE_TO_HAND_LOOK = (
    '<material name="arm" rgba="0.85 0.55 0.2 1" specular="0.3"/>',
    '<material name="arm" rgba="0.85 0.85 0.82 1" specular="0.3"/>',
    'ambient="0.2 0.2 0.2"',
    'ambient="0.3 0.3 0.3"',
)
"""With the camera fixed in the world the arm is in every image, behind the target, partly in
its shadow: painted light grey (as a Panda is) in a brighter room (ambient 0.3), so that
no part of it is darker than the ink threshold (orange in the shadow reaches gray level 40)."""


def _check_carried(scene: Scene) -> None:
    """Eye-to-hand: every object rides on the effector, static in its frame.

    Raises:
        ConfigurationError: an object moves (``wMo(t)`` not :class:`~redservo.scene.Static`).
    """
    for name in scene.names:
        traj = scene.object(name).trajectory
        if not isinstance(traj, Static):
            raise ConfigurationError(
                f"object {name!r} moves ({type(traj).__name__}): with the camera fixed in the "
                "world every object is carried by the end effector, static in its frame",
                argument="scene",
            )


class TrackingStats:
    """How well the joints followed their velocity commands (per joint, rad/s or m/s)."""

    def __init__(self, n: int) -> None:
        self.peak = np.zeros(n)
        """(n,) largest ``|q̇ − q̇_cmd|`` over every physics step so far."""
        self.peak_speed = np.zeros(n)
        """(n,) largest ``|q̇|`` the arm reached (to compare with ``qdot_max``)."""
        self._sq = np.zeros(n)
        self.steps = 0
        """Physics steps recorded."""

    def add(self, err: FloatArray, qdot: FloatArray) -> None:
        """Record one physics step's error ``q̇ − q̇_cmd`` and velocity ``q̇`` (n,)."""
        np.maximum(self.peak_speed, np.abs(qdot), out=self.peak_speed)
        a = np.abs(err)
        np.maximum(self.peak, a, out=self.peak)
        self._sq += a * a
        self.steps += 1

    @property
    def rms(self) -> FloatArray:
        """(n,) RMS of ``|q̇ − q̇_cmd|`` over the steps recorded."""
        return np.sqrt(self._sq / max(self.steps, 1))


class MujocoArm:
    """A robot (and optionally a scene) as a MuJoCo model (module docstring).

    Args:
        robot: The robot (its kinematics define the MJCF exactly: :mod:`redservo.physics.mjcf`);
            an :class:`~redservo.robots.eye_to_hand.EyeToHandRobot`: its carrier, with the
            camera fixed in the world (module docstring).
        scene: Objects to draw (mocap bodies at ``wMo(t)``; eye-to-hand: bodies carried at
            ``eMo = wMo(0)``); None: an empty world.
        camera: Intrinsics and image size of the camera (default :class:`Camera`).
        q_ref: (n,) posture of the gain design (default: the middle of the limits).
        timestep: Physics step (s), in [1e-5, 1] (default 1 ms).
        tracking_time: Time constant of the velocity servo (s), > 0.
        shadows: Let the light cast shadows.
        draw_arm: Draw the arm's bodies in the camera image (False: only the objects).
        obstacles: ``[[obstacles]]`` drawn as geoms at ``wMo(t)`` (world frame).

    Raises:
        ConfigurationError: a step or time constant out of range, or an unusable robot.
    """

    def __init__(
        self,
        robot: Robot,
        scene: Scene | None = None,
        *,
        camera: Camera | None = None,
        q_ref: ArrayLike | None = None,
        timestep: float = 0.001,
        tracking_time: float = 0.02,
        shadows: bool = True,
        draw_arm: bool = True,
        obstacles: Sequence[Obstacle] = (),
    ) -> None:
        if not (math.isfinite(timestep) and MIN_TIMESTEP <= timestep <= 1.0):
            raise ConfigurationError(
                f"timestep must be in [{MIN_TIMESTEP:g}, 1] s, got {timestep!r}",
                argument="timestep",
            )
        if not (math.isfinite(tracking_time) and 0.0 < tracking_time <= 1.0):
            raise ConfigurationError(
                f"tracking_time must be in (0, 1] s, got {tracking_time!r}",
                argument="tracking_time",
            )
        self.mj = require_mujoco()
        self.robot = robot
        self.scene = scene
        self.obstacles = tuple(obstacles)
        """``[[obstacles]]``: mocap bodies ``obs:NAME`` (:mod:`redservo.physics.obstacles`)."""
        self.camera = camera or Camera()
        self._lens = LensWarp(self.camera) if self.camera.distorted else None
        self._pinhole = self.camera if self._lens is None else self._lens.pinhole
        """The pinhole camera MuJoCo renders (:mod:`redservo.physics.lens` for a distorted one)."""
        self.world_camera: FloatArray | None = None
        """Eye-to-hand: ``bMc`` (4x4) of the camera fixed in the world; None: on the arm."""
        carrier = robot
        if isinstance(robot, EyeToHandRobot):
            carrier, self.world_camera = robot.carrier, robot.bMc.copy()
        self.chain: Chain = chain_of(carrier)
        self._Tinv = np.linalg.inv(self.chain.T)
        self.timestep = float(timestep)
        self.tracking_time = float(tracking_time)
        ref = (robot.q_min + robot.q_max) / 2.0 if q_ref is None else as_vector(q_ref, "q_ref")
        wMb = np.eye(4) if scene is None or self.world_camera is not None else scene.wMb
        files: dict[str, bytes] = {}
        self.xml = self._xml(carrier, ref, wMb, files, shadows)
        self.model = self.mj.MjModel.from_xml_string(self.xml, assets=files)
        self.data = self.mj.MjData(self.model)
        self._qadr = np.array([self.model.joint(n).qposadr[0] for n in self.joint_names])
        self._vadr = np.array([self.model.joint(n).dofadr[0] for n in self.joint_names])
        self._site = self.model.site("camera").id
        self._effector = None if self.world_camera is None else self.model.site("effector").id
        self._wMb = wMb
        self._bMw = np.linalg.inv(wMb)
        self.kv = self._gains(ref)
        self.tracking = TrackingStats(robot.n)
        self._renderer: Any = None
        self._options = self.mj.MjvOption()
        self._options.geomgroup[1] = int(bool(draw_arm))  # the arm's geoms are group 1
        self.set_q(ref)

    # -- model ---------------------------------------------------------------------------------

    def _xml(
        self,
        carrier: Robot,
        q_ref: FloatArray,
        wMb: FloatArray,
        files: dict[str, bytes],
        shadows: bool,
    ) -> str:
        """The model's MJCF; sets ``joint_names``, ``drawn`` and ``skipped``."""
        c, h, scene = self._pinhole, self.timestep, self.scene
        bMe0 = carried_at = None
        if self.world_camera is not None:  # eye-to-hand: the scene's frame is the effector's
            bMe0 = np.asarray(carrier.fkine_ee(np.zeros(carrier.n)))
            if scene is not None:
                _check_carried(scene)
                carried_at = bMe0 @ np.linalg.inv(scene.wMb)  # cMo = cMe · inv(wMb) · wMo
        objects, textures, self.drawn, self.skipped = (
            ("", "", [], []) if scene is None else scene_bodies(scene, files, carrier=carried_at)
        )
        carried, objects = (objects, "") if bMe0 is not None else ("", objects)
        arm, self.joint_names = robot_bodies(carrier, self.chain, c, effector=bMe0, carried=carried)
        if self.world_camera is not None:
            arm += camera_xml(self.world_camera, c)
        light, aim = self._light(carrier, q_ref, wMb)
        actuators = "".join(
            f'<velocity name="v{j}" joint="{name}" kv="1"/>'
            for j, name in enumerate(self.joint_names)
        )
        xml = (
            '<mujoco model="redservo">'
            '<compiler angle="radian" autolimits="true"/>'
            f'<option timestep="{h!r}" integrator="implicitfast" gravity="0 0 -9.81"/>'
            '<visual><quality shadowsize="2048"/><map znear="0.005" zfar="30"/>'
            '<headlight ambient="0.2 0.2 0.2" diffuse="0.25 0.25 0.25" specular="0 0 0"/>'
            f'<global offwidth="{c.width}" offheight="{c.height}"/></visual>'
            '<default><geom contype="0" conaffinity="0" density="2000"/></default>'
            f"{_ASSETS.replace('</asset>', textures + '</asset>')}<worldbody>"
            f'<light name="sun" pos="{_vec(light)}" dir="{_vec(aim - light)}" '
            'diffuse="0.5 0.5 0.48" specular="0.1 0.1 0.1" '
            f'cutoff="60" castshadow="{str(shadows).lower()}"/>'
            f'<body name="base" {xml_pose(wMb)}>'
            f"{arm}</body>{objects}{obstacle_bodies(self.obstacles)}</worldbody>"
            f"<actuator>{actuators}</actuator></mujoco>"
        )
        if self.world_camera is not None:
            paint, light_paint, ambient, bright = _EYE_TO_HAND_LOOK
            xml = xml.replace(paint, light_paint).replace(ambient, bright, 1)
        return xml

    def _light(
        self, carrier: Robot, q_ref: FloatArray, wMb: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Where the spot light is and the point it aims at (world frame, m).

        Camera on the arm: 1.5 m above the point midway between the base and the first
        object, shining down. Camera fixed in the world: 1 m above and 0.3 m behind the
        camera, aimed at the first carried object at ``q_ref`` (else the base)."""
        scene = self.scene
        if self.world_camera is None:
            mid = wMb[:3, 3].copy()
            if scene is not None and self.drawn:
                mid = 0.5 * (mid + scene.wMo(self.drawn[0], 0.0)[:3, 3])
            return mid + np.array([0.3, 0.2, 1.5]), mid + np.array([0.0, 0.0, 0.0])
        wMc = wMb @ self.world_camera
        aim = wMb[:3, 3].copy()
        if scene is not None and self.drawn:
            wMe = wMb @ carrier.fkine_ee(np.asarray(q_ref, dtype=float))
            aim = (wMe @ np.linalg.inv(scene.wMb) @ scene.wMo(self.drawn[0], 0.0))[:3, 3]
        return wMc[:3, 3] - 0.3 * wMc[:3, 2] + np.array([0.0, 0.0, 1.0]), aim

    def _gains(self, q_ref: FloatArray) -> FloatArray:
        """``kv_j = (M_jj(q_ref) + armature_j) / tracking_time`` (module docstring)."""
        mj, m, d = self.mj, self.model, self.data
        d.qpos[self._qadr] = self.chain.T @ q_ref
        mj.mj_forward(m, d)
        diag = np.zeros(m.nv)
        e, col = np.zeros(m.nv), np.zeros(m.nv)
        for i in range(m.nv):  # M e_i (mj_mulM, the same call in MuJoCo 3 and 4)
            e[:] = 0.0
            e[i] = 1.0
            mj.mj_mulM(m, d, col, e)
            diag[i] = col[i]
        kv = diag[self._vadr] / self.tracking_time
        for j in range(self.robot.n):
            m.actuator_gainprm[j, 0] = kv[j]
            m.actuator_biasprm[j, 2] = -kv[j]
        return np.asarray(kv)

    # -- state ---------------------------------------------------------------------------------

    @property
    def q(self) -> FloatArray:
        """(n,) joint positions in our coordinates (m or rad)."""
        return np.asarray(self._Tinv @ self.data.qpos[self._qadr])

    @property
    def qdot(self) -> FloatArray:
        """(n,) joint velocities in our coordinates (rad/s or m/s)."""
        return np.asarray(self._Tinv @ self.data.qvel[self._vadr])

    @property
    def time(self) -> float:
        """Simulated time since the last :meth:`set_q` (s)."""
        return float(self.data.time)

    def set_q(self, q: ArrayLike) -> None:
        """Put the arm at rest at ``q`` (n,), command zero, time 0, tracking statistics reset."""
        qa = as_vector(q, "q", self.robot.n)
        d = self.data
        self.mj.mj_resetData(self.model, d)
        d.qpos[self._qadr] = self.chain.T @ qa
        d.ctrl[:] = 0.0
        self.mj.mj_forward(self.model, d)
        self.tracking = TrackingStats(self.robot.n)

    def step(self, qdot_cmd: ArrayLike, duration: float) -> None:
        """Hold the joint velocity command ``qdot_cmd`` (n,) for ``duration`` s (whole steps)."""
        cmd = as_vector(qdot_cmd, "qdot_cmd", self.robot.n)
        steps = max(round(duration / self.timestep), 1)
        mj, m, d = self.mj, self.model, self.data
        d.ctrl[:] = self.chain.T @ cmd
        vadr = self._vadr
        for _ in range(steps):
            mj.mj_step(m, d)
            qdot = self._Tinv @ d.qvel[vadr]
            self.tracking.add(qdot - cmd, qdot)
        mj.mj_kinematics(m, d)  # mj_step leaves the poses of the step's start

    def _site_pose(self, site: int) -> FloatArray:
        """``wMs`` (4x4) of a site, from MuJoCo's state."""
        d = self.data
        wMs = np.eye(4)
        wMs[:3, :3] = d.site_xmat[site].reshape(3, 3)
        wMs[:3, 3] = d.site_xpos[site]
        return wMs

    def camera_pose(self) -> FloatArray:
        """The camera pose as :attr:`robot` defines it (4x4), from MuJoCo's state.

        Camera on the arm: ``bMc``, our camera frame in the robot base frame. Camera fixed
        in the world (an :class:`~redservo.robots.eye_to_hand.EyeToHandRobot`): ``eMc(q) =
        inv(bMe(q)) · bMc``, the fixed camera seen from the end effector, as the wrapper's
        ``fkine`` (the scene's frame is then the effector's)."""
        wMc = self._site_pose(self._site)
        if self._effector is None:
            return np.asarray(self._bMw @ wMc)
        return np.asarray(np.linalg.inv(self._site_pose(self._effector)) @ wMc)

    def object_pose(self, name: str) -> FloatArray:
        """``bMo`` (4x4): a drawn object's frame in the robot base frame, from MuJoCo's state
        (a carried object: ``bMe(q) · eMo``, moved by the physics; else its mocap pose)."""
        d = self.data
        k = self.model.body(f"obj:{name}").id
        wMo = np.eye(4)
        wMo[:3, :3] = d.xmat[k].reshape(3, 3)
        wMo[:3, 3] = d.xpos[k]
        return np.asarray(self._bMw @ wMo)

    # -- images --------------------------------------------------------------------------------

    def render(self, t: float = 0.0) -> NDArray[np.uint8]:
        """The camera's RGB image (H, W, 3) now, the objects at their poses at ``t`` (s)
        (carried objects where the arm holds them)."""
        mj, m, d = self.mj, self.model, self.data
        if self.scene is not None and self.drawn and self._effector is None:
            set_poses(m, d, self.scene, self.drawn, t)
            mj.mj_kinematics(m, d)
        if self.obstacles:
            set_obstacle_poses(m, d, self.obstacles, t)
            mj.mj_kinematics(m, d)
        if self._renderer is None:
            self._renderer = mj.Renderer(m, self._pinhole.height, self._pinhole.width)
        self._renderer.update_scene(d, camera="camera", scene_option=self._options)
        img: NDArray[np.uint8] = self._renderer.render()
        return img if self._lens is None else self._lens.apply(img)

    def close(self) -> None:
        """Free the renderer's OpenGL context (the arm can render again later)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
