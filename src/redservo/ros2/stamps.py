"""ROS 2 stamps (epoch seconds) on the servo loop's monotonic clock.

A ROS 2 driver stamps its messages with its system clock: seconds since 1970 (``Time``).
The servo loop judges every stamp on its monotonic clock (:mod:`redservo.hardware.clock`).
:class:`EpochStamps` converts one to the other with an offset estimated on this machine:

    offset = wall - monotonic,    t_loop = stamp_epoch - offset

``wall`` and ``monotonic`` are read back to back several times; the pair read in the
shortest interval gives the estimate (its error is at most half that interval, about a
microsecond). The conversion is exact when the publisher's system clock *is* this
machine's (the rehearsal arm, a driver on the same computer); for a driver on another
computer its error is the error of the clock synchronisation between the two (NTP: about a
millisecond on a LAN; PTP: microseconds) and must stay below the loop's
``clock_tolerance`` (5 ms by default).

What the loop's clock checks then catch: a driver whose clock is ahead of ours by more
than ``clock_tolerance`` (``clock_fault`` ``future``), stamps that go backwards
(``backwards``), and a driver stamping on another clock, e.g. its own boot time, whose
stamps are then decades old and never fresh (``stale_measurement``, with the hint "is it
on the loop's monotonic clock?"). :meth:`EpochStamps.refresh` re-estimates the offset
(after the system clock was stepped, e.g. by NTP).

Units: seconds.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from redservo.ros2.messages import Time, seconds_to_time, time_to_seconds

__all__ = ["EpochStamps"]


class EpochStamps:
    """Convert ROS 2 stamps (epoch) to the loop's monotonic clock and back.

    Args:
        wall: The system clock (s since the epoch), ``time.time`` on hardware.
        monotonic: The loop's clock (s), ``time.monotonic`` on hardware.
        samples: How many back-to-back readings estimate the offset, >= 1.
    """

    def __init__(
        self,
        wall: Callable[[], float] = time.time,
        monotonic: Callable[[], float] = time.monotonic,
        samples: int = 16,
    ) -> None:
        self.wall, self.monotonic, self.samples = wall, monotonic, max(int(samples), 1)
        self.offset = 0.0
        """``wall - monotonic`` (s)."""
        self.uncertainty = 0.0
        """Half the shortest read interval of the estimate (s): a bound on its error."""
        self.refresh()

    def refresh(self) -> float:
        """Re-estimate :attr:`offset` (s) and return it."""
        best: tuple[float, float] | None = None
        for _ in range(self.samples):
            m1 = self.monotonic()
            w = self.wall()
            m2 = self.monotonic()
            if best is None or m2 - m1 < best[0]:
                best = (m2 - m1, w - 0.5 * (m1 + m2))
        assert best is not None
        self.uncertainty, self.offset = 0.5 * best[0], best[1]
        return self.offset

    def to_loop(self, stamp: Time) -> float:
        """The loop-clock time (s) of the ROS 2 stamp ``stamp`` (epoch)."""
        return time_to_seconds(stamp) - self.offset

    def to_ros(self, t_loop: float) -> Time:
        """The ROS 2 stamp (epoch) of the loop-clock time ``t_loop`` (s)."""
        return seconds_to_time(t_loop + self.offset)
