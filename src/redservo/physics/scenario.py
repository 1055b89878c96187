"""A scenario's ``[simulator] kind = "mujoco"``: the experiment's actuator and sensor.

:func:`attach_mujoco` replaces the built :class:`~redservo.experiment.Experiment`'s
actuator by a :class:`~redservo.physics.MujocoActuator` (the arm's dynamics) and, with
``camera = "rendered"``, its sensor by a :class:`~redservo.physics.MujocoCamera` configured
by the ``[sensor]`` table's image keys. Errors name the scenario key.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from redservo.errors import RedservoError

if TYPE_CHECKING:  # pragma: no cover
    from redservo.experiment import Experiment

__all__ = ["attach_mujoco"]


def attach_mujoco(exp: Experiment) -> None:
    """Give ``exp`` the MuJoCo arm as actuator (and camera); see the module docstring.

    Raises:
        ScenarioError: ``[actuators]`` is set too, the camera is fixed in the world, the
            robot or the sensor settings cannot be modelled, or MuJoCo cannot render offscreen
            here with ``camera = "rendered"`` (names the key).
    """
    sc, spec = exp.scenario, exp.scenario.spec
    sim = spec.simulator
    assert sim is not None and sim.kind == "mujoco"
    if spec.actuators is not None:
        raise sc.error(
            "actuators", "not with [simulator] kind = 'mujoco' (the arm's dynamics replace it)"
        )
    if spec.camera.mount != "hand":
        raise sc.error("camera.mount", "the MuJoCo simulator models an eye-in-hand camera only")
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
