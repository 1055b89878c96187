"""The ``[simulator]`` table of a scenario: kinematic (default) or MuJoCo (docs/physics.md)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from redservo.schema.base import Table, choice, num

__all__ = ["SimulatorSpec"]


class SimulatorSpec(Table):
    """Which simulator runs the scenario: ``kinematic`` (``q ← q + q̇ dt``, or the
    ``[actuators]`` model) or ``mujoco`` (the arm's dynamics in MuJoCo, extra
    ``redservo[mujoco]``, docs/physics.md); with ``mujoco``, ``camera = "rendered"`` measures
    the features in MuJoCo's camera image (with ``[sensor]``'s noise_px, blur_px, seed,
    depth, max_lost_frames), ``"ideal"`` measures them exactly at MuJoCo's camera pose."""

    kind: Literal["kinematic", "mujoco"] = choice(
        "kinematic", what="simulator", description="kinematic | mujoco"
    )
    camera: Literal["ideal", "rendered"] = choice(
        "ideal", what="simulator camera", description="mujoco: ideal | rendered"
    )
    timestep: float = num(0.001, gt=0.0, le=0.1, description="mujoco: physics step (s)")
    tracking_time: float = num(
        0.02, gt=0.0, le=1.0, description="mujoco: time constant of the joint velocity servo (s)"
    )
    shadows: bool = Field(True, description="mujoco: the light casts shadows")
    draw_arm: bool = Field(True, description="mujoco: the arm is drawn (it may hide the target)")
