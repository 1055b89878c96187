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
peak and the RMS of ``|q̇ − q̇_cmd|`` per joint. :meth:`MujocoArm.render` draws the arm's
camera image, lit by one shadow-casting spot light and MuJoCo's head light.

Units: metres, radians, seconds (joint velocities rad/s or m/s).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray, as_vector
from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.physics._mj import require_mujoco
from redservo.physics.mjcf import Chain, chain_of, robot_bodies, xml_pose
from redservo.physics.scenes import scene_bodies, set_poses
from redservo.robots.base import Robot
from redservo.scene import Scene

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
        robot: The robot (its kinematics define the MJCF exactly: :mod:`redservo.physics.mjcf`).
        scene: Objects to draw (mocap bodies at ``wMo(t)``); None: an empty world.
        camera: Intrinsics and image size of the arm's camera (default :class:`Camera`).
        q_ref: (n,) posture of the gain design (default: the middle of the limits).
        timestep: Physics step (s), > 0 (default 1 ms).
        tracking_time: Time constant of the velocity servo (s), > 0.
        shadows: Let the light cast shadows.
        draw_arm: Draw the arm's bodies in the camera image (False: only the objects).

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
    ) -> None:
        for name, value in (("timestep", timestep), ("tracking_time", tracking_time)):
            if not (math.isfinite(value) and 0.0 < value <= 1.0):
                raise ConfigurationError(
                    f"{name} must be in (0, 1] s, got {value!r}", argument=name
                )
        self.mj = require_mujoco()
        self.robot = robot
        self.scene = scene
        self.camera = camera or Camera()
        self.chain: Chain = chain_of(robot)
        self._Tinv = np.linalg.inv(self.chain.T)
        self.timestep = float(timestep)
        self.tracking_time = float(tracking_time)
        wMb = np.eye(4) if scene is None else scene.wMb
        arm_xml, self.joint_names = robot_bodies(robot, self.chain, self.camera)
        files: dict[str, bytes] = {}
        objects, textures, self.drawn, self.skipped = (
            ("", "", [], []) if scene is None else scene_bodies(scene, files)
        )
        self.xml = self._xml(arm_xml, objects, textures, wMb, shadows)
        self.model = self.mj.MjModel.from_xml_string(self.xml, assets=files)
        self.data = self.mj.MjData(self.model)
        self._qadr = np.array([self.model.joint(n).qposadr[0] for n in self.joint_names])
        self._vadr = np.array([self.model.joint(n).dofadr[0] for n in self.joint_names])
        self._site = self.model.site("camera").id
        self._wMb = wMb
        self._bMw = np.linalg.inv(wMb)
        ref = (robot.q_min + robot.q_max) / 2.0 if q_ref is None else as_vector(q_ref, "q_ref")
        self.kv = self._gains(ref)
        self.tracking = TrackingStats(robot.n)
        self._renderer: Any = None
        self._options = self.mj.MjvOption()
        self._options.geomgroup[1] = int(bool(draw_arm))  # the arm's geoms are group 1
        self.set_q(ref)

    # -- model ---------------------------------------------------------------------------------

    def _xml(self, arm: str, objects: str, textures: str, wMb: FloatArray, shadows: bool) -> str:
        c = self.camera
        h = self.timestep
        # A spot light 1.5 m above the point midway between the base and the first object.
        mid = wMb[:3, 3].copy()
        if self.scene is not None and self.drawn:
            mid = 0.5 * (mid + self.scene.wMo(self.drawn[0], 0.0)[:3, 3])
        light = mid + np.array([0.3, 0.2, 1.5])
        actuators = "".join(
            f'<velocity name="v{j}" joint="{name}" kv="1"/>'
            for j, name in enumerate(self.joint_names)
        )
        return (
            '<mujoco model="redservo">'
            '<compiler angle="radian" autolimits="true"/>'
            f'<option timestep="{h!r}" integrator="implicitfast" gravity="0 0 -9.81"/>'
            '<visual><quality shadowsize="2048"/><map znear="0.005" zfar="30"/>'
            '<headlight ambient="0.2 0.2 0.2" diffuse="0.25 0.25 0.25" specular="0 0 0"/>'
            f'<global offwidth="{c.width}" offheight="{c.height}"/></visual>'
            '<default><geom contype="0" conaffinity="0" density="2000"/></default>'
            f"{_ASSETS.replace('</asset>', textures + '</asset>')}<worldbody>"
            f'<light name="sun" pos="{light[0]:.6g} {light[1]:.6g} {light[2]:.6g}" '
            f'dir="{-0.3} {-0.2} {-1.5}" diffuse="0.5 0.5 0.48" specular="0.1 0.1 0.1" '
            f'cutoff="60" castshadow="{str(shadows).lower()}"/>'
            f'<body name="base" {xml_pose(wMb)}>'
            f"{arm}</body>{objects}</worldbody>"
            f"<actuator>{actuators}</actuator></mujoco>"
        )

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

    def camera_pose(self) -> FloatArray:
        """``bMc`` (4x4): our camera frame in the robot base frame, from MuJoCo's state."""
        d = self.data
        wMc = np.eye(4)
        wMc[:3, :3] = d.site_xmat[self._site].reshape(3, 3)
        wMc[:3, 3] = d.site_xpos[self._site]
        return np.asarray(self._bMw @ wMc)

    # -- images --------------------------------------------------------------------------------

    def render(self, t: float = 0.0) -> NDArray[np.uint8]:
        """The arm camera's RGB image (H, W, 3) now, the objects at their poses at ``t`` (s)."""
        mj, m, d = self.mj, self.model, self.data
        if self.scene is not None and self.drawn:
            set_poses(m, d, self.scene, self.drawn, t)
            mj.mj_kinematics(m, d)
        if self._renderer is None:
            self._renderer = mj.Renderer(m, self.camera.height, self.camera.width)
        self._renderer.update_scene(d, camera="camera", scene_option=self._options)
        img: NDArray[np.uint8] = self._renderer.render()
        return img

    def close(self) -> None:
        """Free the renderer's OpenGL context (the arm can render again later)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
