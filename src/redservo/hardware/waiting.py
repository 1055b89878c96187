"""A precise wait for the servo loop's tick: sleep most of the way, then spin on the clock.

``time.sleep`` wakes up late by the kernel's timer slack plus the scheduler's wake-up
latency, and with another Python thread running (the camera's tracker) by up to the
interpreter's switch interval (5 ms by default) while that thread holds the GIL.
:class:`HybridSleep` sleeps until ``spin`` seconds before the deadline, then polls the
loop's clock until the deadline, so the tick starts within a clock read of it whenever the
process got the CPU back within ``spin``. The cost is up to ``spin`` of one core per
period (2 ms per 40 ms at 25 Hz: 5 %).

The scheduling and interpreter settings of a run are in :mod:`redservo.hardware.realtime`.

The clock and the sleep are injectable (a :class:`~redservo.hardware.VirtualClock` in tests).

Units: seconds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from redservo.errors import ConfigurationError

__all__ = ["HybridSleep"]


class HybridSleep:
    """Wait ``dt`` seconds: ``sleep(dt - spin)``, then poll ``clock`` until the deadline.

    Args:
        spin: Seconds (>= 0, finite) before the deadline at which sleeping stops and
            polling starts; 0 is a plain sleep.
        clock: The loop's monotonic clock (s).
        sleep: The sleep function (s).

    Raises:
        ConfigurationError: ``spin`` is negative, not finite or not a number.
    """

    def __init__(
        self,
        spin: float = 0.002,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        ok = isinstance(spin, int | float) and not isinstance(spin, bool) and math.isfinite(spin)
        if not ok or spin < 0:
            raise ConfigurationError(
                f"spin must be a finite number of seconds >= 0, got {spin!r}", argument="spin"
            )
        self.spin, self.clock, self.sleep = float(spin), clock, sleep

    def __call__(self, dt: float) -> None:
        """Return at ``clock() + dt`` (at once when ``dt <= 0``)."""
        deadline = self.clock() + dt
        if dt - self.spin > 0:
            self.sleep(dt - self.spin)
        while self.clock() < deadline:
            pass
