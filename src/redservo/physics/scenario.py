"""A scenario's ``[simulator] kind = "mujoco"``: the experiment's actuator and sensor.

:func:`attach_mujoco` replaces the built :class:`~redservo.experiment.Experiment`'s
actuator by a :class:`~redservo.physics.MujocoActuator` (the arm's dynamics) and, with
``camera = "rendered"``, its sensor by a :class:`~redservo.physics.MujocoCamera` configured
by the ``[sensor]`` table's image keys. The camera is the scenario's: on the arm, or with
``camera.mount = "world"`` fixed in the world, the objects carried by the arm's last link
(the experiment's robot is then the eye-to-hand wrapper, which :class:`MujocoArm` models).
Errors name the scenario key.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from redservo.errors import RedservoError

if TYPE_CHECKING:  # pragma: no cover
    from redservo.experiment import Experiment

__all__ = ["attach_mujoco"]


def _refuse_distortion(exp: Experiment) -> None:
    """MuJoCo renders a pinhole image: a distorted lens would be undistorted wrongly."""
    sc, spec = exp.scenario, exp.scenario.spec
    k = spec.sensor.distortion
    if exp.camera.distorted:
        key = "camera.file" if spec.camera.file is not None else "camera.distortion"
    elif any(v != 0.0 for v in (k if isinstance(k, list) else [k])):
        key = "sensor.distortion"
    else:
        return
    raise sc.error(
        key,
        "MuJoCo renders a pinhole camera: with simulator.camera = 'rendered' the lens must "
        "have no distortion (or set simulator.camera = 'ideal')",
    )


def attach_mujoco(exp: Experiment) -> None:
    """Give ``exp`` the MuJoCo arm as actuator (and camera); see the module docstring.

    Raises:
        ScenarioError: ``[actuators]`` is set too, the robot or the sensor settings cannot
            be modelled, or with ``camera = "rendered"``: MuJoCo cannot render offscreen here,
            or the lens is distorted (MuJoCo renders a pinhole camera) (names the key).
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
            camera=exp.camera,
            q_ref=exp.q0,
            timestep=sim.timestep,
            tracking_time=sim.tracking_time,
            shadows=sim.shadows,
            draw_arm=sim.draw_arm,
        )
    except RedservoError as exc:
        raise sc.error("simulator", str(exc)) from None
    ratio = exp.options.dt / sim.timestep
    if abs(ratio - round(ratio)) > 1e-6:
        raise sc.error(
            "simulator.timestep",
            f"must divide the control period dt = {exp.options.dt} s, got {sim.timestep} s",
        )
    exp.actuator = MujocoActuator(arm)
    if sim.camera == "rendered":
        _refuse_distortion(exp)
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
