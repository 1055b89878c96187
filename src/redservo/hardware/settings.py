"""Checks of the servo loop's settings (:class:`~redservo.hardware.ServoLoop`'s ``Raises``):
its period, timeouts and gain, and what its controller may be given without a scene.

Units: seconds; ``λ`` in 1/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from redservo.control import Objective
from redservo.errors import ConfigurationError

__all__ = ["check_servo_control", "check_timing"]


def _positive(value: float | None, name: str, unit: str) -> None:
    if value is not None and not (math.isfinite(value) and value > 0.0):
        raise ConfigurationError(f"{name} must be a positive number ({unit}), got {value!r}")


def check_timing(
    period: float,
    watchdog_timeout: float,
    clock_tolerance: float,
    duration: float | None,
    tolerance: float,
    lam: Any,
) -> None:
    """Check the loop's period, timeouts and gain (:class:`ServoLoop`'s ``Raises``)."""
    _positive(period, "period", "s")
    _positive(watchdog_timeout, "watchdog_timeout", "s")
    _positive(duration, "duration", "s")
    _positive(tolerance, "tolerance", "task units")
    if isinstance(lam, int | float):
        _positive(float(lam), "lam", "1/s")
    if watchdog_timeout < period:
        raise ConfigurationError(
            f"watchdog_timeout ({watchdog_timeout!r} s) must be at least the period ({period!r} s)"
        )
    if not (math.isfinite(clock_tolerance) and 0.0 <= clock_tolerance < watchdog_timeout):
        raise ConfigurationError(
            f"clock_tolerance must be >= 0 s and below watchdog_timeout "
            f"({watchdog_timeout!r} s), got {clock_tolerance!r}",
            argument="clock_tolerance",
        )


def check_servo_control(objectives: Sequence[Objective], feedforward: str) -> None:
    """The servo loop has no scene: no ``"known"`` feed-forward, no objective needing it."""
    if feedforward not in ("none", "estimated"):
        why = " ('known' needs the scene's motion, which only the simulator has)"
        raise ConfigurationError(
            f"feedforward must be 'none' or 'estimated' in the servo loop, got {feedforward!r}"
            + (why if feedforward == "known" else ""),
            argument="feedforward",
        )
    for i, obj in enumerate(objectives):
        if getattr(obj, "needs_scene", False):
            raise ConfigurationError(
                f"objectives[{i}] ({type(obj).__name__}) needs the scene, which the servo loop "
                "does not have: give it one (e.g. OcclusionAvoidance(occlusion, scene=...))",
                argument=f"objectives[{i}]",
            )
