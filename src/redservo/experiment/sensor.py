"""The scenario's sensor for :func:`redservo.experiment.build.build`: the ideal or image sensor of
``[sensor]``, and the camera's timing around it (:mod:`redservo.sensors.timing`)."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from redservo.errors import RedservoError
from redservo.sensors.timing import CameraTiming, timed

if TYPE_CHECKING:  # pragma: no cover
    from redservo.camera import Camera
    from redservo.control import ImageMotionLimit
    from redservo.experiment.build import Experiment
    from redservo.scenario import Scenario
    from redservo.sensors import Sensor

__all__ = ["TIMING_KEYS", "attach_timing", "motion_limit", "scenario_sensor"]

TIMING_KEYS = ("rate", "latency", "exposure", "compensate_latency", "motion_limit")
"""The ``[sensor]`` keys of the camera's timing (:mod:`redservo.sensors.timing`), not the
image sensor's."""


def scenario_sensor(sc: Scenario, camera: Camera) -> Sensor | None:
    """The image sensor of ``[sensor] kind = "image"``, or None (the ideal sensor).

    Raises:
        ScenarioError: a key the image sensor refuses (names it).
    """
    s = sc.spec.sensor
    if s.kind == "ideal":
        return None
    from redservo.vision import ImageSensor

    kwargs = s.model_dump(exclude={"kind", *TIMING_KEYS})
    try:
        return ImageSensor(camera, **kwargs)
    except RedservoError as exc:
        arg = exc.argument
        raise sc.error(f"sensor.{arg}" if arg in kwargs else "sensor.kind", str(exc)) from None


def attach_timing(sc: Scenario, exp: Experiment) -> None:
    """Set ``exp.timing`` from ``[sensor]`` and wrap ``exp.sensor`` (built, the MuJoCo camera
    included; None for the ideal one) in it when it is not the perfect camera.

    Raises:
        ScenarioError: the sensor cannot model the exposure (names ``sensor.exposure``).
    """
    s = sc.spec.sensor
    exp.timing = CameraTiming(s.rate, s.latency, s.exposure)
    if s.motion_limit > 0.0:
        limit = motion_limit(exp.sensor, exp.camera, s.motion_limit, s.rate, exp.options.dt)
        exp.options = dataclasses.replace(exp.options, image_motion=limit)
    try:
        exp.sensor = timed(exp.sensor, exp.timing, exp.options.dt)
    except RedservoError as exc:
        raise sc.error(f"sensor.{exc.argument or 'exposure'}", str(exc)) from None


def motion_limit(
    sensor: Sensor | None, camera: Camera, fraction: float, rate: float | None, dt: float
) -> ImageMotionLimit:
    """The camera-motion limit of ``[sensor] motion_limit``: a point moves at most
    ``fraction`` of the tracker's gate (pixels; an image sensor's own, else the gate of the
    default dot tracker) per frame, frames ``1/rate`` s apart (``dt`` without a rate)."""
    from redservo.control import ImageMotionLimit
    from redservo.vision.render import RenderOptions
    from redservo.vision.sensor import tracking_gate_px
    from redservo.vision.terms import dot_gate_px

    gate = tracking_gate_px(sensor) or dot_gate_px(RenderOptions())
    period = dt if rate is None else 1.0 / rate
    return ImageMotionLimit.from_camera(
        focal_px=min(camera.px, camera.py), gate_px=gate, frame_period=period, fraction=fraction
    )
