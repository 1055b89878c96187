"""A scenario's camera: its intrinsics (typed in or from a calibration file) and its mount.

:func:`scenario_camera` builds the :class:`~redservo.camera.Camera` of ``[camera]``
(:func:`redservo.calibration.files.load_camera` for ``file``); :func:`mounted_robot` wraps the
robot in :class:`~redservo.robots.eye_to_hand.EyeToHandRobot` for ``mount = "world"``,
after checking what an eye-to-hand set-up supports: every object carried by the end
effector (``pose_in_effector``, or ``pose_in_camera`` at the start) and static on it, no
``start_pose`` (a camera pose reached by inverse kinematics means nothing when the camera
does not move), no hand-eye error (the calibration that matters is ``wMc``), no occluder.
"""

from __future__ import annotations

from redservo.camera import DISTORTION_NAMES, Camera
from redservo.errors import RedservoError
from redservo.robots.base import Robot
from redservo.scenario import Scenario

__all__ = ["mounted_robot", "scenario_camera"]


def scenario_camera(sc: Scenario) -> Camera:
    """The camera of ``sc``'s ``[camera]`` table.

    Raises:
        ScenarioError: the calibration file is unreadable or the values make no camera
            (names the file and the key).
    """
    c = sc.spec.camera
    if c.file is not None:
        from redservo.calibration.files import load_camera

        try:
            camera = load_camera(c.file)
        except RedservoError as exc:
            raise sc.error("camera.file", str(exc)) from None
    else:
        dist = dict(zip(DISTORTION_NAMES, c.distortion or (), strict=False))
        try:
            camera = Camera(c.px, c.py, c.u0, c.v0, c.width, c.height, **dist)
        except RedservoError as exc:
            raise sc.error("camera", str(exc)) from None
    k = sc.spec.sensor.distortion
    if camera.distorted and any(v != 0.0 for v in (k if isinstance(k, list) else [k])):
        raise sc.error(
            "sensor.distortion",
            "the camera already has its lens distortion (camera.file or camera.distortion); "
            "give it in one place",
        )
    return camera


def mounted_robot(sc: Scenario, robot: Robot) -> Robot:
    """``robot`` itself for ``camera.mount = "hand"``; for ``"world"`` the
    :class:`~redservo.robots.eye_to_hand.EyeToHandRobot` carrying the objects.

    Raises:
        ScenarioError: a key an eye-to-hand set-up does not support (module docstring).
    """
    spec = sc.spec
    cam = spec.camera
    if cam.mount == "hand":
        for i, o in enumerate(spec.objects):
            if o.pose_in_effector is not None:
                raise sc.error(
                    f"objects[{i}].pose_in_effector",
                    "only with camera.mount = 'world' (a target carried by the robot)",
                )
        return robot
    if spec.robot.start_pose is not None:
        raise sc.error(
            "robot.start_pose",
            "not with camera.mount = 'world' (the camera does not move); give q0",
        )
    if spec.simulation.eMc_error is not None:
        raise sc.error(
            "simulation.eMc_error",
            "not with camera.mount = 'world': the camera is not on the robot",
        )
    if spec.occlusion is not None:
        raise sc.error("occlusion", "not supported with camera.mount = 'world'")
    for i, o in enumerate(spec.objects):
        if o.pose_in_effector is None and o.pose_in_camera is None:
            raise sc.error(
                f"objects[{i}].pose_in_effector",
                "camera.mount = 'world': every object rides on the end effector; give "
                "pose_in_effector (eMo) or pose_in_camera (at the start)",
            )
        if o.motion is not None:
            raise sc.error(
                f"objects[{i}].motion", "not with camera.mount = 'world' (the robot carries it)"
            )
    from redservo.robots.eye_to_hand import EyeToHandRobot

    assert cam.pose is not None  # the schema requires it
    try:
        return EyeToHandRobot(robot, cam.pose.matrix())
    except RedservoError as exc:  # pragma: no cover - the schema validated the pose
        raise sc.error("camera.pose", str(exc)) from None
