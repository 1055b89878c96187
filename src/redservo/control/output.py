"""The Controller's output stage: what happens to the law's command before it is sent.

In this order (each a uniform scaling towards zero, so the law's choice of direction is
kept):

1. the output saturation ``qdot_saturation`` (rad/s or m/s): no joint faster than it;
2. the camera-motion limit (:mod:`redservo.control.image_motion`): no image point moves
   further between two frames than the tracker follows;
3. the final guard (:func:`~redservo.control.law_output.guarded_output`) on a command either
   scaled: a scaling keeps the velocity and position limits but may break ``qddot_max``
   against the previous command;
4. the distance shield (:func:`~redservo.control.avoidance.shield_command`): no collision
   pair closer than ``d_safe`` within one period (it wins over the acceleration limit, and
   says so).

The same stage runs after the compiled step and after the object path, so every loop that
drives the :class:`~redservo.control.Controller` (simulate, the servo loop) gets it. Units:
rad/s or m/s, s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from redservo._validation import FloatArray
from redservo.control.avoidance import shield_command
from redservo.control.image_motion import limit_image_motion
from redservo.control.law_output import guarded_output

if TYPE_CHECKING:
    from redservo.control.controller import Controller
    from redservo.redundancy.base import Diagnostics
    from redservo.task import TaskState

__all__ = ["final_guard", "saturate", "shape_output"]


def saturate(qdot: FloatArray, saturation: FloatArray | None) -> tuple[FloatArray, bool]:
    """``(q̇, scaled)``: the command scaled down uniformly so that no joint exceeds
    ``saturation`` (n,) (rad/s or m/s), or unchanged (None: no saturation)."""
    if saturation is None:
        return qdot, False
    ratio = float(np.max(np.abs(qdot) / saturation))
    return (qdot / ratio, True) if ratio > 1.0 else (qdot, False)


def final_guard(
    ctl: Controller, qdot: FloatArray, diag: Diagnostics, q: FloatArray, prev: FloatArray | None
) -> tuple[FloatArray, Diagnostics]:
    """The servo loop's final guard (:func:`~redservo.control.law_output.guarded_output`)
    on a user's own law's output, and again on any command the output stage scaled; the
    position step unless the law has ``shield = False``."""
    shield = bool(getattr(ctl.law, "shield", True))
    qdot, diag, _ = guarded_output(
        qdot, diag, q=q, qdot_prev=prev, limits=ctl.limits, dt=ctl.dt, shield=shield
    )
    return qdot, diag


def shape_output(
    ctl: Controller,
    qdot: FloatArray,
    diag: Diagnostics,
    state: TaskState,
    q: FloatArray,
    J: FloatArray | None,
    t: float,
    prev: FloatArray | None,
) -> tuple[FloatArray, Diagnostics, bool]:
    """Steps 1-4 of the module docstring: ``(q̇, diagnostics, saturated)``; ``J`` the model
    Jacobian (6, n) at ``q`` when the caller has it, ``t`` the step's time (s)."""
    ctl.stage = "saturation"
    qdot, saturated = saturate(qdot, ctl.qdot_saturation)
    limited = False
    if ctl.image_motion is not None:
        Ja = ctl.jacobian(q) if J is None else J
        qdot, diag, limited = limit_image_motion(
            qdot, diag, state.L, Ja, ctl._motion_rows, ctl.image_motion
        )
    if saturated or limited:
        ctl.stage = "guard"
        qdot, diag = final_guard(ctl, qdot, diag, q, prev)
    ctl.stage = "guard"
    acc = ctl.limits.qddot_max
    return (
        *shield_command(ctl.collision, ctl.robot, qdot, diag, q, t, ctl.dt, prev, acc),
        saturated,
    )
