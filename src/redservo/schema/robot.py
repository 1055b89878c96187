"""Schema of a scenario's ``[robot]`` table: a shipped model, a URDF file or an MJCF file.

Split from :mod:`redservo.schema.scenario` (re-exported there): which robot, where it starts,
its limits. ``docs/scenarios.md`` is generated from it.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from redservo.schema.base import BIG, Doc, PerJoint, Table, choice, fail, num, unknown_name
from redservo.schema.scene import Pose

__all__ = ["RobotSpec"]

_Joint = Annotated[float, Field(ge=-BIG, le=BIG, allow_inf_nan=False)]
_Joints = Annotated[
    list[_Joint], Field(min_length=1, max_length=1000), Doc("array of numbers (one per joint)")
]


class RobotSpec(Table):
    """The robot: a shipped model, a URDF file *or* an MJCF file, the start and the limits."""

    model: str | None = Field(
        None, description="a shipped robot (redservo list): afma6 | humanoid9 | panda"
    )
    options: dict[str, Any] = Field(
        {}, description="constructor options of the model (afma6: tool)"
    )
    urdf: str | None = Field(
        None,
        description="a URDF file (path relative to the scenario file) or a shipped one: panda | "
        "ur5e (needs redservo[urdf])",
    )
    kind: Literal["mjcf"] | None = choice(
        None, what="robot kind", description="mjcf: a robot read from an MJCF file (robot.file)"
    )
    file: str | None = Field(
        None,
        description="MJCF: the file (path relative to the scenario file) or a shipped trimmed "
        "MuJoCo Menagerie one: panda | ur5e (needs redservo[mujoco])",
    )
    base: str | None = Field(None, description="MJCF: the base body (default: the top body)")
    tip: str = Field(
        "camera", description="MJCF: the site, MuJoCo camera or body where the camera is"
    )
    camera_link: str = Field("camera_link", description="URDF: the link the camera is fixed to")
    base_link: str | None = Field(None, description="URDF: the base link (default: the root)")
    joints: list[str] | None = Field(
        None,
        min_length=1,
        description="URDF, MJCF: the servoed joints (default: every movable one)",
    )
    locked_q: dict[str, Annotated[float, Field(ge=-BIG, le=BIG, allow_inf_nan=False)]] | None = (
        Field(None, description="URDF, MJCF: positions (m or rad) of the locked joints")
    )
    eMc: Pose | None = Field(
        None, description="URDF, MJCF: camera pose in camera_link or tip (default identity)"
    )
    q0: _Joints | None = Field(None, description="start configuration (m or rad)")
    start_pose: Pose | None = Field(
        None,
        description="...or a start camera pose in the base frame, reached by inverse kinematics",
    )
    q_guess: _Joints | None = Field(None, description="initial guess of the inverse kinematics")
    rho: float = num(0.1, gt=0.0, lt=0.5, description="band width of the thresholds (CM01 eq. 3)")
    margin: float = num(
        0.01,
        ge=0.0,
        lt=0.5,
        description="keep-out of the position shield at each limit, fraction of the range, < rho",
    )
    q_min: _Joints | None = Field(None, description="override of the lower joint limits (m or rad)")
    q_max: _Joints | None = Field(None, description="override of the upper joint limits (m or rad)")
    qdot_max: (
        Annotated[float | list[float], PerJoint(gt=0.0, le=BIG, unit="rad/s or m/s")] | None
    ) = Field(
        None, description="override of the joint velocity limits (default: the robot's datasheet)"
    )
    qddot_max: (
        Annotated[float | list[float], PerJoint(gt=0.0, le=1e5, unit="rad/s² or m/s²")] | None
    ) = Field(None, description="override of the joint acceleration limits")

    @field_validator("model")
    @classmethod
    def _known_model(cls, v: str | None) -> str | None:
        from redservo.robots import ROBOTS

        if v is not None and v.strip().lower() not in ROBOTS:
            fail(unknown_name("robot", v, ROBOTS))
        return v

    @model_validator(mode="after")
    def _consistent(self) -> RobotSpec:
        self._one_robot()
        if self.q0 is None and self.start_pose is None:
            fail("missing: give q0 (joint positions) or start_pose (camera pose)", "q0")
        if self.q0 is not None and self.start_pose is not None:
            fail(
                "give either q0 (joint positions) or start_pose (camera pose), not both",
                "start_pose",
            )
        if self.q_guess is not None and self.start_pose is None:
            fail("only with start_pose (it seeds the inverse kinematics)", "q_guess")
        if self.margin >= self.rho:
            fail(
                f"must be below rho = {self.rho:g} (the shield's keep-out lies inside the band), "
                f"got {self.margin:g}",
                "margin",
            )
        if self.q_min is not None and self.q_max is not None:
            if len(self.q_min) != len(self.q_max):
                fail(f"q_min has {len(self.q_min)} entries and q_max {len(self.q_max)}", "q_max")
            for i, (lo, hi) in enumerate(zip(self.q_min, self.q_max)):
                if not lo < hi:
                    fail(
                        f"q_max[{i}] = {hi:g} must be above q_min[{i}] = {lo:g} (inverted limits)",
                        f"q_max[{i}]",
                    )
        return self

    def _one_robot(self) -> None:
        """Exactly one of model, urdf, kind = "mjcf"; each kind's keys only with it."""
        given = [k for k in ("model", "urdf", "kind") if getattr(self, k) is not None]
        if not given:
            fail(
                "missing required key (a shipped robot; or robot.urdf, a URDF file; or "
                'robot.kind = "mjcf" with robot.file, an MJCF file)',
                "model",
            )
        if len(given) > 1:
            fail(f"give one of model, urdf, kind = 'mjcf'; got {' and '.join(given)}", given[1])
        who, chosen = given[0], self.model_fields_set
        if who == "model":
            for key in ("joints", "locked_q", "eMc"):
                if key in chosen:
                    fail("only with robot.urdf or robot.kind = 'mjcf', not with robot.model", key)
        for owner, keys in _OWN.items():
            for key in keys:
                if owner != who and key in chosen:
                    fail(f"only with {_WHO[owner]}, not with {_WHO[who]}", key)
        if self.kind == "mjcf" and self.file is None:
            fail("missing: robot.kind = 'mjcf' needs robot.file, the MJCF file", "file")


_OWN = {
    "model": ("options",),
    "urdf": ("camera_link", "base_link"),
    "kind": ("file", "base", "tip"),
}
_WHO = {"model": "robot.model", "urdf": "robot.urdf", "kind": "robot.kind = 'mjcf'"}
