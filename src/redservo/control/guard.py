"""The last check on a joint-velocity command before it is sent.

The shipped control laws already honour the limits in their own safety layer
(docs/safety.md); this guard is the last line of defence against a law that does not (a
custom one, a bug, a NaN). The servo loop applies it to every command it sends
(:class:`~redservo.hardware.ServoLoop`), and :class:`~redservo.control.Controller` to the
output of every law that is not a shipped one, so that a user driving the Controller
directly gets the same guarantees. In order:

1. **Finite**: a command holding NaN or inf is replaced by zeros and flagged; the loop
   then stops the robot.
2. **Velocity**: if some ``|q̇_i| > q̇max_i`` the *whole* command is scaled down by the
   largest ratio, so its direction (and the camera motion's direction) is kept.
3. **Acceleration**: if ``|q̇_i - q̇prev_i| > q̈max_i T`` the *change* is scaled down
   uniformly. The result is a convex combination of the previous and the new command,
   so when both respect ``q̇max`` it does too.
4. **Position**: no joint may be commanded to move beyond its safe range
   ``[q̄_min + margin, q̄_max - margin]`` within the time the command may stay in force,
   ``T_hold`` (``hold``; the servo loop passes its ``max_hold``, by default its watchdog
   timeout, not the nominal period: a late loop holds a command longer than planned):
   ``q_i + q̇_i T_hold`` must stay in the safe range, so an outward velocity is reduced to
   ``(bound - q_i) / T_hold`` (0 if the joint is already there or beyond). This clips joints
   individually (the direction changes): it is a last resort, not a control strategy.
   Staying inside the range comes first: this clip may change the command by more than
   ``q̈max T``. Every such excess is reported (``acceleration_exceeded``: the joints whose
   command changed by more than ``q̈max_i T`` from ``q̇prev``, checked on the command
   returned, whatever caused it, including a non-finite command replaced by zeros) and
   counted by the servo loop (``summary["acceleration_exceeded"]``).

Units: rad/s or m/s for velocities, rad/s² or m/s² for accelerations, s for ``T``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.limits import JointLimits

__all__ = ["GuardReport", "guard_command"]


class GuardReport(NamedTuple):
    """What :func:`guard_command` changed (all neutral when the command passed unchanged)."""

    non_finite: bool = False
    """The command held NaN or inf and was replaced by zeros."""
    velocity_scale: float = 1.0
    """Factor in (0, 1] applied to the whole command to respect ``qdot_max``."""
    acceleration_scale: float = 1.0
    """Factor in [0, 1] applied to the change of command to respect ``qddot_max``."""
    position_clipped: tuple[int, ...] = ()
    """Joints whose outward velocity was reduced to stay within the safe range."""
    acceleration_exceeded: tuple[int, ...] = ()
    """Joints whose returned command differs from ``qdot_prev`` by more than ``q̈max_i T``
    (the position clip or a non-finite command replaced by zeros can cause it)."""

    @property
    def changed(self) -> bool:
        """True when the command was modified (an acceleration excess is a consequence of a
        change, not a change of its own)."""
        return (
            self.non_finite
            or self.velocity_scale < 1.0
            or self.acceleration_scale < 1.0
            or bool(self.position_clipped)
        )


def guard_command(
    qdot: FloatArray,
    *,
    q: FloatArray,
    qdot_prev: FloatArray,
    limits: JointLimits,
    period: float,
    hold: float | None = None,
    position: bool = True,
) -> tuple[FloatArray, GuardReport]:
    """Return the command to send and what was changed (see the module docstring).

    Args:
        qdot: (n,) command from the law (rad/s or m/s).
        q: (n,) measured joint positions (m or rad).
        qdot_prev: (n,) the command sent last period (zeros at start).
        limits: Position limits, and the optional ``qdot_max``, ``qddot_max`` and margin.
        period: Control period T (s): the acceleration bound is ``q̈max T``.
        hold: Longest time (s) the command may stay in force, ``T_hold >= T``; the position
            step plans over it (None: one period).
        position: Apply step 4 (the position limits); False for a law whose position
            shield the user switched off (``shield = False``).
    """
    cmd = np.array(qdot, dtype=float)
    qddot_max = getattr(limits, "qddot_max", None)
    if not np.all(np.isfinite(cmd)):
        zero = np.zeros_like(cmd)
        return zero, GuardReport(
            True, acceleration_exceeded=_exceeded(zero, qdot_prev, qddot_max, period)
        )
    v_scale = a_scale = 1.0
    qdot_max = getattr(limits, "qdot_max", None)
    if qdot_max is not None:
        with np.errstate(over="ignore"):  # a finite 1e308 overflows to ratio inf: scale 0
            ratio = float(np.max(np.abs(cmd) / qdot_max))
        if ratio > 1.0:
            v_scale = 1.0 / ratio
            cmd *= v_scale
    if qddot_max is not None:
        delta = cmd - qdot_prev
        ratio = float(np.max(np.abs(delta) / (qddot_max * period)))
        if ratio > 1.0:
            a_scale = 1.0 / ratio
            cmd = qdot_prev + delta * a_scale
    if not position:
        exceeded = _exceeded(cmd, qdot_prev, qddot_max, period)
        return cmd, GuardReport(False, v_scale, a_scale, (), exceeded)
    lo = getattr(limits, "safe_min", limits.q_min)
    hi = getattr(limits, "safe_max", limits.q_max)
    horizon = period if hold is None else max(float(hold), period)
    up = np.maximum((hi - q) / horizon, 0.0)
    down = np.minimum((lo - q) / horizon, 0.0)
    clipped = np.flatnonzero((cmd > up) | (cmd < down))
    if clipped.size:
        cmd = np.clip(cmd, down, up)
    exceeded = _exceeded(cmd, qdot_prev, qddot_max, period)
    return cmd, GuardReport(False, v_scale, a_scale, tuple(int(i) for i in clipped), exceeded)


_ACCEL_RTOL = 1e-9
"""Relative slack on ``|q̇ - q̇prev| <= q̈max T``: the uniform scaling of step 3 lands on the
bound up to roundoff (the run summary's acceleration check uses the same slack)."""


def _exceeded(
    cmd: FloatArray, qdot_prev: FloatArray, qddot_max: FloatArray | None, period: float
) -> tuple[int, ...]:
    """Joints whose change of command exceeds ``q̈max_i T`` (none without ``qddot_max``)."""
    if qddot_max is None:
        return ()
    bound = np.asarray(qddot_max, dtype=float) * period * (1.0 + _ACCEL_RTOL) + 1e-15
    return tuple(int(i) for i in np.flatnonzero(np.abs(cmd - qdot_prev) > bound))
