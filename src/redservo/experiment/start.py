"""The start of a built scenario is checked before it runs: every observed object valid, in
front of the camera and in the image, and the image sensor (when there is one) sees the
features. Errors name the scenario's key (``objects[i]``, ``sensor``).

Units: metres, radians, pixels.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from redservo.collision.start import check_clear, scenario_collision
from redservo.errors import RedservoError
from redservo.scenario import Scenario
from redservo.schema.scenario import ScenarioSpec

if TYPE_CHECKING:
    from redservo.experiment.build import Experiment

__all__ = ["attach_collision", "check_start"]


def attach_collision(sc: Scenario, exp: Experiment) -> None:
    """Give ``exp``'s options the run's collision set-up (``[collision]`` and the obstacles,
    :func:`~redservo.collision.start.scenario_collision`), the self pairs checked at ``q0``."""
    from dataclasses import replace

    coll = scenario_collision(sc, exp.robot, exp.q0, exp.obstacles)
    exp.options = replace(exp.options, collision=coll)


def check_start(sc: Scenario, spec: ScenarioSpec, exp: Experiment) -> None:
    """Every observed object is valid, in front of the camera and in the image at the start,
    and no obstacle touches the robot."""
    check_clear(sc, exp.robot, exp.q0, exp.obstacles)
    bMc = exp.robot.fkine(exp.q0)
    index = {o.name: i for i, o in enumerate(spec.objects)}
    for term in exp.task.terms:
        i = index[term.target]
        cMo = exp.scene.cMo(term.target, bMc, 0.0)
        try:
            term.feature.measure(cMo)
        except RedservoError as exc:
            raise sc.error(
                f"objects[{i}]", f"the task is not valid at the start configuration: {exc}"
            ) from None
        if not spec.simulation.check_image:
            continue
        P = spec.objects[i].reference_points() @ cMo[:3, :3].T + cMo[:3, 3]
        margin = spec.simulation.image_margin_px
        if np.any(P[:, 2] <= 1e-9):
            raise sc.error(f"objects[{i}]", f"{term.target!r} is behind the camera at the start")
        uv = exp.camera.normalized_to_pixel(P[:, :2] / P[:, 2:3])
        inside = exp.camera.in_image(P[:, :2] / P[:, 2:3], margin_px=margin)
        if not np.all(inside):
            j = int(np.flatnonzero(~np.asarray(inside))[0])
            cam = exp.camera
            raise sc.error(
                f"objects[{i}]",
                f"{term.target!r} is outside the image at the start: point {j} at "
                f"(u, v) = ({uv[j][0]:.1f}, {uv[j][1]:.1f}) px, image {cam.width}x{cam.height} "
                f"px, margin {margin:g} px",
            )
    if exp.sensor is not None:  # the image sensor must see the features at the start
        exp.sensor.reset()
        try:
            reading = exp.sensor.read(exp.task, exp.scene, bMc, 0.0)
        except RedservoError as exc:
            raise sc.error("sensor", str(exc)) from None
        exp.sensor.reset()
        if reading.s is None or reading.lost:
            raise sc.error(
                "sensor",
                f"the image sensor does not see the features at the start (lost: "
                f"{list(reading.lost)}): {reading.reason}",
            )
