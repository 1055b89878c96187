"""The ``[sensor]`` table of a scenario: where the features come from, and the camera's timing.

The timing keys (``rate``, ``latency``, ``exposure``; docs/camera-timing.md) are checked
here against each other, and against the run (``control.dt``, ``simulation.max_iterations``)
by :func:`check_timing`, called with the scenario's other cross-references.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field, model_validator

from redservo.schema.base import PerJoint, Table, choice, fail, integer, num
from redservo.sensors.timing import MAX_LATENCY, MAX_RATE

if TYPE_CHECKING:  # pragma: no cover
    from redservo.schema.scenario import ScenarioSpec

__all__ = ["SensorSpec", "check_timing"]

_SEED_MAX = 2**63 - 1


class SensorSpec(Table):
    """Where the features come from: exact (``ideal``) or detected in a rendered camera image
    (``image``: :class:`redservo.vision.ImageSensor`, extra ``redservo[vision]``,
    docs/vision.md). The other keys configure the image sensor; with ``kind = "ideal"`` they
    are checked but unused, so that ``--set sensor.kind="image"`` switches a scenario to
    images with its own settings. ``rate``, ``latency`` and ``exposure`` give either sensor a
    real camera's timing (docs/camera-timing.md); their defaults are today's perfect camera."""

    kind: Literal["ideal", "image"] = choice("ideal", what="sensor", description="ideal | image")
    noise_px: float = num(
        0.0, ge=0.0, le=255.0, description="Gaussian image noise, std in gray levels (0-255)"
    )
    blur_px: float = num(0.0, ge=0.0, le=50.0, description="Gaussian blur, std (px)")
    distortion: Annotated[
        float | list[float],
        PerJoint(ge=-10.0, le=10.0, doc="number k1 or array [k1, k2], each in [-10, 10]"),
    ] = Field(0.0, description="radial distortion k1, or [k1, k2]")
    depth: Literal["desired", "estimated", "true", "pose"] = choice(
        "desired",
        what="sensor depth",
        description="depth given to the controller: desired | estimated (from the image) | "
        "true | pose (from the dots' PnP pose)",
    )
    seed: int = integer(0, ge=0, le=_SEED_MAX, description="seed of the image noise and texture")
    max_lost_frames: int = integer(
        3, ge=0, le=1_000_000, description="a feature lost longer stops the run (feature_lost)"
    )
    texture: bool = Field(False, description="textured background")
    ellipse_method: Literal["moments", "contour"] = choice(
        "moments", what="ellipse method", description="how a sphere's ellipse is measured"
    )
    dot_radius_px: float = num(4.0, gt=0.0, le=100.0, description="radius of a rendered dot (px)")
    rate: float | None = num(
        None,
        gt=0.0,
        le=MAX_RATE,
        description="frames per second (Hz), default one frame every control period",
    )
    latency: float = num(
        0.0,
        ge=0.0,
        description="mid-exposure to measurement available (s), below the servo loop's "
        "watchdog_timeout (0.5 s)",
    )
    exposure: float = num(0.0, ge=0.0, le=1.0, description="exposure time (s): motion blur")
    compensate_latency: bool = Field(
        True, description="bring each measurement to the present with the commands sent since"
    )
    motion_limit: float = num(
        0.0,
        ge=0.0,
        le=1.0,
        description="camera-motion limit: an image point moves at most this fraction of the "
        "tracker's gate per frame (0: none; redservo.control.ImageMotionLimit)",
    )

    @model_validator(mode="after")
    def _image_keys(self) -> SensorSpec:
        if isinstance(self.distortion, list) and len(self.distortion) > 2:
            fail("expected k1 or [k1, k2]", "distortion")
        if self.latency >= MAX_LATENCY:
            fail(
                f"latency {self.latency:g} s is not below the servo loop's watchdog_timeout "
                f"({MAX_LATENCY:g} s): its measurements would be stale on arrival and the "
                "compensation could not bridge them",
                "latency",
            )
        if self.rate is not None and self.exposure > 1.0 / self.rate:
            fail(
                f"exposure {self.exposure:g} s is longer than the frame interval "
                f"1/rate = {1.0 / self.rate:g} s",
                "exposure",
            )
        if self.latency < self.exposure / 2.0:
            fail(
                f"latency {self.latency:g} s is shorter than half the exposure "
                f"({self.exposure / 2.0:g} s): a frame cannot be read before it is exposed",
                "latency",
            )
        return self


def check_timing(spec: ScenarioSpec) -> None:
    """The camera timing against the run: the latency within the run's duration, and (with
    no ``rate``: a frame every control period) the exposure within the control period."""
    sensor, dt = spec.sensor, spec.control.dt
    duration = spec.simulation.max_iterations * dt
    if sensor.latency >= duration:
        fail(
            f"latency {sensor.latency:g} s is not shorter than the run "
            f"(simulation.max_iterations x control.dt = {duration:g} s)",
            "sensor.latency",
        )
    if sensor.rate is None and sensor.exposure > dt:
        fail(
            f"exposure {sensor.exposure:g} s is longer than the frame interval (no rate: one "
            f"frame every control.dt = {dt:g} s)",
            "sensor.exposure",
        )
