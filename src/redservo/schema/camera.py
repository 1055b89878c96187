"""Schema of a scenario's ``[camera]`` table (:class:`CameraSpec`): intrinsics, distortion,
a calibration file, and the mount (eye-in-hand or fixed in the world, eye-to-hand)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from redservo.schema.base import Doc, Table, choice, fail, integer, num
from redservo.schema.scene import Pose

__all__ = ["CameraSpec"]


class CameraSpec(Table):
    """Intrinsics, distortion and image size (pixels), typed in or read from a calibration
    ``file``; where the camera is (``mount``: on the robot or fixed in the world)."""

    file: str | None = Field(
        None,
        description="an OpenCV (YAML/XML/JSON) or ROS camera_info intrinsics file, path "
        "relative to the scenario file; replaces px, py, u0, v0, width, height, distortion",
    )

    px: float = num(600.0, gt=0.0, le=1e5, description="pixels per normalized unit, horizontally")
    py: float = num(600.0, gt=0.0, le=1e5, description="pixels per normalized unit, vertically")
    u0: float = num(320.0, ge=-1e5, le=1e5, description="principal point (px)")
    v0: float = num(240.0, ge=-1e5, le=1e5, description="principal point (px)")
    width: int = integer(640, ge=1, le=8192, description="image width (px)")
    height: int = integer(480, ge=1, le=8192, description="image height (px)")
    distortion: (
        Annotated[
            list[Annotated[float, Field(ge=-10.0, le=10.0, allow_inf_nan=False)]],
            Doc("array of 4 or 5 numbers"),
        ]
        | None
    ) = Field(
        None,
        min_length=4,
        max_length=5,
        description="OpenCV lens distortion [k1, k2, p1, p2] or [k1, k2, p1, p2, k3]",
    )
    mount: Literal["hand", "world"] = choice(
        "hand",
        what="camera mount",
        description="hand (on the robot, eye-in-hand) | world (fixed, eye-to-hand: the robot "
        "carries the objects, each placed by pose_in_effector or pose_in_camera)",
    )
    pose: Pose | None = Field(
        None, description="mount = world: the camera pose wMc in the world (robot base) frame"
    )

    @model_validator(mode="after")
    def _consistent(self) -> CameraSpec:
        if self.file is not None:
            for key in ("px", "py", "u0", "v0", "width", "height", "distortion"):
                if key in self.model_fields_set:
                    fail("give either file (a calibration file) or the intrinsics, not both", key)
        if self.mount == "world" and self.pose is None:
            fail("missing: mount = 'world' needs the camera pose wMc", "pose")
        if self.mount == "hand" and self.pose is not None:
            fail("only with mount = 'world' (an eye-in-hand camera's pose is robot.eMc)", "pose")
        return self
