"""Schema of a scenario file (``docs/scenarios.md`` is generated from it).

:class:`ScenarioSpec` is the whole file; validating it checks every key, type, range and
name, and the references between tables (a feature's object, the occluder, the length
of ``task.desired``), without building anything: geometry (a target behind the camera,
``q0`` outside the robot's limits) is checked by :func:`redservo.experiment.build.build`.
"""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal

from pydantic import Field, field_validator, model_validator

from redservo.schema.base import (
    BIG,
    Doc,
    PerJoint,
    Table,
    choice,
    fail,
    integer,
    num,
    unknown_name,
)
from redservo.schema.camera import CameraSpec
from redservo.schema.features import AnyFeature
from redservo.schema.obstacles import CollisionSpec, ObstacleSpec, OcclusionSpec
from redservo.schema.robot import RobotSpec
from redservo.schema.scene import AnyObject, Pose
from redservo.schema.sensor import SensorSpec
from redservo.schema.simulator import SimulatorSpec
from redservo.task import DepthMode

__all__ = [
    "ActuatorsSpec",
    "CameraSpec",
    "ControlSpec",
    "GainSpec",
    "OcclusionSpec",
    "RobotSpec",
    "ScenarioSpec",
    "SensorSpec",
    "SimulationSpec",
    "TaskSpec",
]

MAX_ITERATIONS = 10_000_000
"""Largest ``simulation.max_iterations`` (the log is preallocated)."""
SEED_MAX = 2**63 - 1
DT_MIN = 1e-4
"""Shortest ``control.dt`` (s): a 10 kHz loop, ten times the fastest joint-level interfaces
(1 kHz); no robot runs faster, and a run's iterations would cover almost no time
(``dt = 1e-300`` ran 600 motionless iterations)."""
LAM_MIN = 1e-3
"""Smallest gain λ (1/s): a time constant 1/λ of 1000 s (17 min); below it the error does not
visibly decrease in any run, e.g. ``lam = 1e-300`` ran 600 motionless iterations."""


class TaskSpec(Table):
    """The desired features: ``desired`` (s*) or ``desired_pose`` (what the camera sees there)."""

    desired: (
        Annotated[
            list[Annotated[float, Field(ge=-1e6, le=1e6, allow_inf_nan=False)]],
            Doc("array of numbers"),
        ]
        | None
    ) = Field(None, min_length=1, max_length=100_000, description="s*, stacked in feature order")
    desired_pose: Pose | None = Field(
        None,
        description="c*Mo of the first feature's object: s* is what the camera sees there "
        "(needed by moments and by depth = desired | mean)",
    )
    depth: DepthMode = choice(
        "current", what="depth mode", description="depth in L: current | desired | mean"
    )


class GainSpec(Table):
    """Adaptive gain λ(‖e1‖∞) = (zero − inf) exp(−slope ‖e1‖∞ / (zero − inf)) + inf."""

    zero: float = num(ge=LAM_MIN, le=BIG, description="λ0 = λ(0) (1/s)")
    inf: float = num(
        ge=LAM_MIN,
        le=BIG,
        description="λ∞, the gain for large errors (1/s), <= zero; at least 0.001 as lam",
    )
    slope: float = num(ge=0.0, le=1e6, description="λ'0, minus the slope at 0 (1/s per task unit)")

    @model_validator(mode="after")
    def _ordered(self) -> GainSpec:
        if self.inf > self.zero:
            fail(f"must be <= zero = {self.zero:g} (λ∞ <= λ0), got {self.inf:g}", "inf")
        return self


class ControlSpec(Table):
    """The control law and its gains."""

    method: str = Field(description="the control law (redservo list)")
    lam: float | None = num(
        None,
        ge=LAM_MIN,
        le=BIG,
        description="constant gain λ (1/s), default 0.5; at least 0.001, a time constant 1/λ "
        "of 1000 s (lam = 1e-300 ran 600 motionless iterations)",
    )
    gain: GainSpec | None = Field(None, description="...or an adaptive gain (exclusive with lam)")
    dt: float = num(
        0.04,
        ge=DT_MIN,
        le=10.0,
        description="control period (s); at least 1e-4, a 10 kHz loop, ten times the 1 kHz of "
        "the fastest robot interfaces (dt = 1e-300 ran 600 motionless iterations)",
    )
    shield: bool = Field(True, description="position shield: no command may cross the margin")
    robust: bool = Field(True, description="filtered inverses near singularities (paper laws)")
    scaling: Literal["uniform", "secondary-first"] = choice(
        "uniform", what="scaling", description="how a command is scaled into the rate limits"
    )
    options: dict[str, Any] = Field({}, description="the method's keyword options, e.g. alpha")

    @field_validator("method")
    @classmethod
    def _known_method(cls, v: str) -> str:
        from redservo.redundancy import METHODS

        if v not in METHODS:
            fail(unknown_name("method", v, METHODS))
        return v

    @model_validator(mode="after")
    def _law(self) -> ControlSpec:
        from redservo.errors import RedservoError
        from redservo.redundancy import make_law

        if self.lam is not None and self.gain is not None:
            fail("give either lam (constant) or gain (adaptive), not both", "gain")
        for key in ("shield", "robust", "scaling"):
            if key in self.options:
                fail(f"set control.{key}, not control.options.{key}", f"options.{key}")
        try:
            make_law(self.method, **self.options)
        except RedservoError as exc:
            arg = getattr(exc, "argument", None)
            fail(str(exc), f"options.{arg}" if arg and arg in self.options else "options")
        return self


class SimulationSpec(Table):
    """Simulator options (all optional)."""

    RENAMED: ClassVar[dict[str, tuple[str, str]]] = {
        "qdot_max": ("qdot_saturation", "the output saturation after the law")
    }
    """Keys renamed so that ``qdot_max`` means one thing in a file (the law's joint limit)."""

    max_iterations: int = integer(1000, ge=1, le=MAX_ITERATIONS, description="iteration cap")
    tolerance: float = num(1e-3, gt=0.0, le=BIG, description="convergence threshold on ‖e1‖")
    tolerance_px: float | None = num(
        None,
        gt=0.0,
        le=1e4,
        description="convergence threshold in pixels, ‖e1‖·f < tolerance_px with f the focal "
        "length (px); replaces tolerance (images, docs/camera-timing.md)",
    )
    stop_at_convergence: bool = Field(True, description="false for tracking tasks")
    min_margin: float = num(
        0.01,
        ge=0.0,
        lt=0.5,
        description="success needs every joint this far from its limits (fraction of the range)",
    )
    qdot_saturation: (
        Annotated[float | list[float], PerJoint(gt=0.0, le=BIG, unit="rad/s or m/s")] | None
    ) = Field(
        None,
        description="output saturation after the law: the command scaled down uniformly "
        "(the law itself honours robot.qdot_max)",
    )
    noise_std: float = num(0.0, ge=0.0, le=10.0, description="feature noise (feature units)")
    seed: int = integer(0, ge=0, le=SEED_MAX, description="seed of the feature noise")
    depth_scale: float = num(
        1.0, gt=0.0, le=100.0, description="the controller's depth is depth_scale × Z"
    )
    eMc_error: Pose | None = Field(None, description="hand-eye calibration error of the controller")
    feedforward: Literal["none", "known", "estimated"] = choice(
        "none", what="feed-forward", description="none | known | estimated (moving targets)"
    )
    image_margin_px: float = num(
        0.0, ge=0.0, le=1e4, description="lost this close to the border (px)"
    )
    check_image: bool = Field(
        True, description="stop with target_lost when an object leaves the image"
    )


class ActuatorsSpec(Table):
    """Joint actuator model: delay, lag, saturation, encoder (redservo.hardware.actuators)."""

    RENAMED: ClassVar[dict[str, tuple[str, str]]] = {
        "qdot_max": ("velocity_saturation", "the drives' velocity saturation"),
        "qddot_max": ("acceleration_saturation", "the drives' acceleration saturation"),
    }
    """Keys renamed so that ``qdot_max`` means one thing in a file (the law's joint limit)."""
    MODEL_KEYS: ClassVar[dict[str, str]] = {
        "velocity_saturation": "qdot_max",
        "acceleration_saturation": "qddot_max",
    }
    """The keyword of :class:`~redservo.hardware.actuators.ActuatorModel` a key sets, where it
    differs."""

    tau: Annotated[float | list[float], PerJoint(ge=0.0, le=100.0, unit="s")] = Field(
        0.0, description="time constant of the first-order velocity lag (s), 0 = none"
    )
    delay_steps: int = integer(0, ge=0, le=1000, description="transport delay (control periods)")
    velocity_saturation: (
        Annotated[float | list[float], PerJoint(gt=0.0, le=BIG, unit="rad/s or m/s")] | None
    ) = Field(None, description="velocity saturation of the drives")
    acceleration_saturation: (
        Annotated[float | list[float], PerJoint(gt=0.0, le=1e5, unit="rad/s² or m/s²")] | None
    ) = Field(None, description="acceleration saturation of the drives")
    encoder_resolution: (
        Annotated[float | list[float], PerJoint(gt=0.0, le=1.0, unit="rad or m")] | None
    ) = Field(None, description="encoder step (rad or m), default continuous")
    encoder_noise_std: Annotated[float | list[float], PerJoint(ge=0.0, le=1.0, unit="rad or m")] = (
        Field(0.0, description="encoder noise std (rad or m)")
    )
    seed: int | None = integer(None, ge=0, le=SEED_MAX, description="seed of the encoder noise")


class ScenarioSpec(Table):
    """A scenario file."""

    name: str | None = Field(None, max_length=200, description="default: the file name")
    description: str = Field("", max_length=2000, description="one line")
    paper: str = Field("", max_length=200, description="free text, e.g. CM01 §V-A1")
    robot: RobotSpec = Field(description="the robot")
    camera: CameraSpec = Field(
        default_factory=lambda: CameraSpec.model_validate({}), description="the camera"
    )
    objects: list[AnyObject] = Field(min_length=1, max_length=1000, description="the scene")
    obstacles: list[ObstacleSpec] = Field([], max_length=1000, description="not to be touched")
    features: list[AnyFeature] = Field(
        min_length=1, max_length=1000, description="stacked in order"
    )
    task: TaskSpec = Field(description="the desired features")
    control: ControlSpec = Field(description="the control law")
    simulation: SimulationSpec = Field(
        default_factory=lambda: SimulationSpec.model_validate({}), description="simulator options"
    )
    occlusion: OcclusionSpec | None = Field(None, description="an occluding sphere")
    collision: CollisionSpec | None = Field(None, description="collision avoidance")
    sensor: SensorSpec = Field(
        default_factory=lambda: SensorSpec.model_validate({}),
        description="where the features come from",
    )
    actuators: ActuatorsSpec | None = Field(
        None, description="joint actuator model (default ideal)"
    )
    simulator: SimulatorSpec | None = Field(
        None, description="kinematic (default) or MuJoCo simulator"
    )

    @model_validator(mode="after")
    def _references(self) -> ScenarioSpec:
        from redservo.schema.crossref import check_references

        check_references(self)
        return self
