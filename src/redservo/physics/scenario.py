"""A scenario's ``[simulator] kind = "mujoco"``: the experiment's actuator and sensor.

:func:`attach_mujoco` replaces the built :class:`~redservo.experiment.build.Experiment`'s
actuator by a :class:`~redservo.physics.MujocoActuator` (the arm's dynamics) and, with
``camera = "rendered"``, its sensor by a :class:`~redservo.physics.MujocoCamera` configured
by the ``[sensor]`` table's image keys. The camera is the scenario's: on the arm, or with
``camera.mount = "world"`` fixed in the world, the objects carried by the arm's last link
(the experiment's robot is then the eye-to-hand wrapper, which :class:`MujocoArm` models).
A distorted lens (the camera's, or ``[sensor] distortion``) is rendered by
:mod:`redservo.physics.lens`. Errors name the scenario key.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from redservo.errors import RedservoError
from redservo.schema.simulator import MAX_PHYSICS_STEPS

if TYPE_CHECKING:  # pragma: no cover
    from redservo.camera import Camera
    from redservo.experiment.build import Experiment

__all__ = ["attach_mujoco"]


def _arm_camera(exp: Experiment) -> Camera:
    """The camera MuJoCo renders: the scenario's, with ``[sensor] distortion`` (radial ``k1``
    or ``[k1, k2]`` of an undistorted camera, as the image sensor applies it) as its lens."""
    k = exp.scenario.spec.sensor.distortion
    ks = [float(v) for v in (k if isinstance(k, list) else [k])]
    if not any(ks):
        return exp.camera
    k1, k2 = [*ks, 0.0][:2]
    return dataclasses.replace(exp.camera, k1=k1, k2=k2)


def attach_mujoco(exp: Experiment) -> None:
    """Give ``exp`` the MuJoCo arm as actuator (and camera); see the module docstring.

    Raises:
        ScenarioError: ``[actuators]`` is set too, the robot or the sensor settings cannot
            be modelled, or MuJoCo cannot render offscreen here with ``camera = "rendered"``
            (names the key).
    """
    sc, spec = exp.scenario, exp.scenario.spec
    sim = spec.simulator
    assert sim is not None and sim.kind == "mujoco"
    if spec.actuators is not None:
        raise sc.error(
            "actuators", "not with [simulator] kind = 'mujoco' (the arm's dynamics replace it)"
        )
    from redservo.physics.arm import MujocoArm
    from redservo.physics.robot import MujocoActuator

    try:
        arm = MujocoArm(
            exp.robot,
            exp.scene,
            camera=_arm_camera(exp) if sim.camera == "rendered" else exp.camera,
            q_ref=exp.q0,
            timestep=sim.timestep,
            tracking_time=sim.tracking_time,
            shadows=sim.shadows,
            draw_arm=sim.draw_arm,
            obstacles=exp.obstacles,
        )
    except RedservoError as exc:
        raise sc.error("simulator", str(exc)) from None
    ratio = exp.options.dt / sim.timestep
    if ratio > MAX_PHYSICS_STEPS + 1e-6:
        raise sc.error(
            "simulator.timestep",
            f"must be at least dt / {MAX_PHYSICS_STEPS} = {exp.options.dt / MAX_PHYSICS_STEPS:g} s "
            f"(at most {MAX_PHYSICS_STEPS} physics steps per control period dt = "
            f"{exp.options.dt} s), got {sim.timestep} s: {ratio:.3g} steps per period",
        )
    if abs(ratio - round(ratio)) > 1e-6:
        raise sc.error(
            "simulator.timestep",
            f"must divide the control period dt = {exp.options.dt} s, got {sim.timestep} s",
        )
    exp.actuator = MujocoActuator(arm)
    if sim.camera == "rendered":
        from redservo.physics._mj import rendering_available
        from redservo.physics.camera import MujocoCamera

        why = rendering_available()
        if why is not None:
            raise sc.error(
                "simulator.camera",
                f"{why}; install Debian's libegl1 libegl-mesa0 libgl1-mesa-dri (make test does, "
                "as root), or set simulator.camera = 'ideal'",
            )

        s = spec.sensor
        try:
            exp.sensor = MujocoCamera(
                arm,
                noise_px=s.noise_px,
                blur_px=s.blur_px,
                seed=s.seed,
                depth=s.depth,
                max_lost_frames=s.max_lost_frames,
            )
        except RedservoError as exc:
            raise sc.error("sensor", str(exc)) from None
