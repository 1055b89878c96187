"""Checks of the servo loop's settings (:class:`~redservo.hardware.ServoLoop`'s ``Raises``):
its period, timeouts and gain, and what its controller may be given without a scene; and
:class:`LoopSettings`, which stores the checked timing and end-of-run settings.

Units: seconds; ``λ`` in 1/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Literal

from redservo.control import Objective
from redservo.errors import ConfigurationError
from redservo.hardware.supervision import Supervision

__all__ = ["LoopSettings", "check_servo_control", "check_timing"]


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


class LoopSettings:
    """The timing and end-of-run settings a servo loop keeps (base of ``ServoLoop``).

    Units: seconds; ``tolerance`` in task units.
    """

    max_iterations: int | None
    duration: float | None
    tolerance: float
    stop_at_convergence: bool
    on_missing: Literal["hold", "zero"]
    period: float
    watchdog_timeout: float
    clock_tolerance: float
    clock: Callable[[], float]
    sleep: Callable[[float], None]
    supervision: Supervision

    def _set_ending(
        self,
        max_iterations: int | None,
        duration: float | None,
        tolerance: float,
        stop_at_convergence: bool,
        on_missing: Literal["hold", "zero"],
    ) -> None:
        """Check and store when the run ends and what it does without a measurement.

        ``duration`` in s, ``tolerance`` in task units (already checked by ``check_timing``).

        Raises:
            ConfigurationError: ``max_iterations`` below 1, or ``on_missing`` neither
                ``"hold"`` nor ``"zero"``.
        """
        if max_iterations is not None and max_iterations < 1:
            raise ConfigurationError(f"max_iterations must be >= 1, got {max_iterations!r}")
        if on_missing not in ("hold", "zero"):
            raise ConfigurationError(f"on_missing must be 'hold' or 'zero', got {on_missing!r}")
        self.max_iterations = max_iterations
        self.duration = duration
        self.tolerance = float(tolerance)
        self.stop_at_convergence = stop_at_convergence
        self.on_missing = on_missing

    def _set_timing(
        self,
        period: float,
        watchdog_timeout: float,
        clock_tolerance: float,
        clock: Callable[[], float],
        sleep: Callable[[float], None],
        supervision: Supervision | None,
    ) -> None:
        """Store the loop's clock and timing thresholds (s), ``max_hold`` resolved.

        The values were checked by ``check_timing``; ``supervision`` None means
        ``Supervision()``.
        """
        self.period = float(period)
        self.watchdog_timeout = float(watchdog_timeout)
        self.clock_tolerance = float(clock_tolerance)
        self.clock = clock
        self.sleep = sleep
        self.supervision = (supervision or Supervision()).resolved(self.period, watchdog_timeout)
        """The timing and following thresholds, ``max_hold`` resolved."""
