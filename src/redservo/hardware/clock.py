"""The servo loop's clock contract: how it judges the time stamps of joint readings and of
feature measurements (docs/real-robot.md, "The clock contract").

Every stamp is in the **loop's clock**: monotonic seconds, the ``clock`` the
:class:`~redservo.hardware.ServoLoop` was given (``time.monotonic`` on hardware). For each
stream (the joint readings, the measurements) a :class:`StampWatch` checks every stamp it
is shown, against the loop's clock read just after the reading arrived:

* a stamp that is not a finite number (NaN, ±inf, None) is a fault (``non_finite``);
* a stamp later than the loop's clock by more than ``clock_tolerance`` is a fault
  (``future``): typically ``time.time()`` (epoch seconds, ~1.7e9) given to a loop on
  ``time.monotonic()``;
* a stamp earlier than the newest stamp seen on the same stream is a fault (``backwards``);
* an equal stamp is a repeated reading ("nothing new yet"): allowed, but not fresh.

A reading is **fresh** when its stamp is new (strictly greater than every earlier one) and
at most ``watchdog_timeout`` old. The stream's **age** is judged on the stamp *and* on the
arrival: ``max(now - stamp, now - arrival)`` of its last fresh reading (``now - t0`` before
the first one), so a source that keeps returning the same, older or future-by-a-little
stamps cannot keep the watchdog happy for longer than ``watchdog_timeout`` of the loop's
own clock.

Units: seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

from redservo._validation import is_number

__all__ = ["ClockFault", "FaultKind", "StampSource", "StampWatch"]

StampSource = Literal["joints", "measurement"]
FaultKind = Literal["non_finite", "future", "backwards"]

_STAMP_NAME: dict[str, str] = {
    "joints": "the joint readings' time stamp t (robot.read_joints())",
    "measurement": "the measurement's time stamp t_measured (source.measure())",
}


class ClockFault(NamedTuple):
    """A time stamp that breaks the clock contract (the module docstring)."""

    source: StampSource
    """``"joints"`` (``robot.read_joints()``) or ``"measurement"`` (``source.measure()``)."""
    kind: FaultKind
    """``"non_finite"``, ``"future"`` or ``"backwards"``."""
    stamp: float
    """The offending stamp (s; NaN when it was not a number)."""
    reference: float
    """What it was compared with (s): the loop's clock (``future``), the newest earlier
    stamp (``backwards``), NaN (``non_finite``)."""
    tolerance: float
    """The loop's ``clock_tolerance`` (s)."""
    given: str = ""
    """``repr`` of the stamp as given, when it was not a number (``stamp`` is then NaN)."""

    def message(self) -> str:
        """One sentence: which stamp, what is wrong with it, and the likely cause."""
        what = _STAMP_NAME[self.source]
        if self.kind == "non_finite":
            return f"{what} is {self.given or repr(self.stamp)}, not a finite number of seconds"
        if self.kind == "future":
            return (
                f"{what} = {self.stamp!r} s is {self.stamp - self.reference:.6g} s ahead of the "
                f"loop's clock ({self.reference!r} s; clock_tolerance {self.tolerance:g} s): "
                "stamps must be on the loop's monotonic clock (time.monotonic(), not time.time())"
            )
        return (
            f"{what} went backwards, from {self.reference!r} s to {self.stamp!r} s "
            f"({self.stamp - self.reference:.6g} s): stamps must increase"
        )

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (``summary["clock_fault"]``); non-finite numbers become strings."""
        d: dict[str, Any] = self._asdict()
        for key in ("stamp", "reference"):
            if not math.isfinite(d[key]):
                d[key] = repr(d[key])
        return d


@dataclass
class StampWatch:
    """Freshness and clock checks of one time-stamped stream (module docstring).

    Args:
        source: Which stream (named in faults and messages).
        tolerance: How far (s) a stamp may be ahead of the loop's clock, >= 0.
        timeout: The watchdog timeout (s): a reading older than this is not fresh, and the
            stream is stale when its last fresh reading is older than this.
        t0: The loop's start (s): the age of a stream before its first fresh reading.
    """

    source: StampSource
    tolerance: float
    timeout: float
    t0: float
    newest: float | None = None
    """The newest stamp seen (s), fresh or not."""
    fresh_stamp: float | None = None
    """Stamp of the last fresh reading (s)."""
    fresh_arrival: float | None = None
    """Loop time when the last fresh reading arrived (s)."""

    def observe(self, stamp: object, arrival: float) -> ClockFault | bool:
        """Check ``stamp`` of a reading that arrived at loop time ``arrival`` (s).

        Returns:
            A :class:`ClockFault` when the stamp breaks the contract; otherwise True when the
            reading is fresh (new and at most ``timeout`` old), False when it is not (a
            repeated stamp, or a new one already too old).
        """
        if is_number(stamp):  # only real numbers are stamps: "1.0" or True is a fault
            t, given = float(stamp), ""  # type: ignore[arg-type]
        else:
            t, given = math.nan, repr(stamp)[:80]
        if not math.isfinite(t):
            return ClockFault(self.source, "non_finite", t, math.nan, self.tolerance, given)
        if t > arrival + self.tolerance:
            return ClockFault(self.source, "future", t, arrival, self.tolerance)
        if self.newest is not None and t < self.newest:
            return ClockFault(self.source, "backwards", t, self.newest, self.tolerance)
        if self.newest is not None and t == self.newest:
            return False
        self.newest = t
        if arrival - t > self.timeout:
            return False
        self.fresh_stamp, self.fresh_arrival = t, arrival
        return True

    @property
    def ever_fresh(self) -> bool:
        """True once a fresh reading arrived."""
        return self.fresh_arrival is not None

    def age(self, now: float) -> float:
        """Seconds since the last fresh reading at loop time ``now``, on its stamp and on its
        arrival (the larger); since the start when there was none."""
        if self.fresh_stamp is None or self.fresh_arrival is None:
            return now - self.t0
        return max(now - self.fresh_stamp, now - self.fresh_arrival)

    def stale(self, now: float) -> bool:
        """True when the last fresh reading is more than ``timeout`` old at ``now``."""
        return self.age(now) > self.timeout

    def describe_stale(self, now: float) -> str:
        """Why the stream is stale at ``now``: its age, and how old its newest stamp is (with a
        hint when no reading was ever fresh: the stamps may not be on the loop's clock)."""
        what = "joint readings" if self.source == "joints" else "measurement"
        text = f"no fresh {what} for {self.age(now):.3f} s (watchdog_timeout {self.timeout:g} s)"
        if self.newest is not None:
            old = now - self.newest
            text += f"; the newest time stamp seen, {self.newest!r} s, is {old:.6g} s old"
            if not self.ever_fresh and old > self.timeout:
                text += " (is it on the loop's monotonic clock?)"
        return text
