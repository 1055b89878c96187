"""The ``[simulator]`` table of a scenario: kinematic (default) or MuJoCo (docs/physics.md)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from redservo.schema.base import Table, choice, num

__all__ = ["MAX_PHYSICS_STEPS", "MIN_TIMESTEP", "SimulatorSpec"]

MIN_TIMESTEP = 1e-5
"""Smallest MuJoCo ``timestep`` (s): 10 µs, a hundredth of the 1 ms default (``timestep =
1e-12`` asked for 4·10¹⁰ physics steps per control period, a run that never ends)."""
MAX_PHYSICS_STEPS = 10_000
"""Most MuJoCo physics steps per control period (``dt / timestep``): 10 s of control period
at the 1 ms default."""


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
    timestep: float = num(
        0.001,
        ge=MIN_TIMESTEP,
        le=0.1,
        description="mujoco: physics step (s); at least 1e-5 (10 µs), and at most "
        f"{MAX_PHYSICS_STEPS} physics steps per control period dt",
    )
    tracking_time: float = num(
        0.02, gt=0.0, le=1.0, description="mujoco: time constant of the joint velocity servo (s)"
    )
    shadows: bool = Field(True, description="mujoco: the light casts shadows")
    draw_arm: bool = Field(True, description="mujoco: the arm is drawn (it may hide the target)")
