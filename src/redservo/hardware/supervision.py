"""What the servo loop checks beyond the clock contract: that it runs on time, and that the
robot follows its commands (docs/real-robot.md, "Late loops and robots that do not follow").

**Hold bound.** A velocity command stays in force until the next one is sent. The guard
(:func:`~redservo.hardware.guard_command`) therefore plans every command over ``max_hold``
seconds, not over the nominal period ``T``: joint i is commanded

    ``q̂_i + q̇_i · T_hold ∈ [q̄_min,i + margin_i, q̄_max,i - margin_i]``,

with ``T_hold = max_hold`` (default ``watchdog_timeout``) and ``q̂`` the reading advanced by
the command still in force up to the guard's time. The loop keeps its side of the bargain: a
send that comes more than ``max_hold`` after the previous send (a slow law, a loaded machine,
a read or a ``send_velocity`` that blocked) is not made; the run ends with the outcome ``late``
and ``robot.stop()`` sends zeros. ``max_overruns`` consecutive overruns (iterations that end
after their next tick) end it the same way, however short each one.

**Following.** Over every window of ``follow_window`` seconds the loop compares the measured
joint motion ``Δq = q(t) - q(t - W)`` with the commanded one ``Δq_c = ∫ q̇_cmd dt`` (the
commands sent, integrated over the time each was in force). When ``‖Δq_c‖ >=
follow_min_motion`` and

    ``‖Δq - Δq_c‖ > follow_tolerance · ‖Δq_c‖ + follow_lag · max ‖q̇_cmd‖``

(the last term allows for the actuator's delay and lag, in seconds of the fastest command of
the window) the run ends with ``not_following``. **Frozen encoder**: ``frozen_cycles``
consecutive fresh readings with identical ``q`` while the commands in force over them add up
to ``>= frozen_motion`` end the run with ``not_following`` too. Both thresholds are options
(:class:`Supervision`), so a robot with a long transport delay or an encoder with a coarse
resolution can widen them.

Units: seconds, metres or radians (``follow_min_motion``, ``frozen_motion``, the norms).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError

__all__ = ["FollowWatch", "Supervision"]


@dataclass(frozen=True)
class Supervision:
    """The servo loop's timing and following thresholds (the module docstring).

    Args:
        max_hold: Longest time (s) a command may stay in force; the guard plans with it.
            None: the loop's ``watchdog_timeout``. At least the period.
        max_overruns: Consecutive overruns that end the run (integer >= 1).
        follow_window: Window W of the following check (s), > 0.
        follow_tolerance: Allowed relative deviation of the measured motion from the
            commanded one, >= 0.
        follow_lag: Allowance (s) for the actuator's delay and lag, >= 0.
        follow_min_motion: Commanded motion (m or rad, norm over the joints) below which a
            window is not judged, > 0.
        frozen_cycles: Identical consecutive readings that make a frozen encoder (>= 2);
            above the actuator's transport delay in periods.
        frozen_motion: Commanded motion (m or rad, norm) over those readings that makes
            them suspicious, > 0.
    """

    max_hold: float | None = None
    max_overruns: int = 5
    follow_window: float = 1.0
    follow_tolerance: float = 0.5
    follow_lag: float = 0.3
    follow_min_motion: float = 0.05
    frozen_cycles: int = 5
    frozen_motion: float = 1e-3

    def resolved(self, period: float, watchdog_timeout: float) -> Supervision:
        """Return a copy with ``max_hold`` filled in, every value checked.

        Raises:
            ConfigurationError: a value is out of its range (the error names the field).
        """
        hold = watchdog_timeout if self.max_hold is None else self.max_hold
        if not (math.isfinite(hold) and hold >= period):
            raise ConfigurationError(
                f"supervision.max_hold must be a number of seconds >= the period ({period!r} s), "
                f"got {hold!r}",
                argument="supervision.max_hold",
            )
        for name, low in (("max_overruns", 1), ("frozen_cycles", 2)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ConfigurationError(
                    f"supervision.{name} must be an integer >= {low}, got {value!r}",
                    argument=f"supervision.{name}",
                )
        for name, strict in (
            ("follow_window", True),
            ("follow_tolerance", False),
            ("follow_lag", False),
            ("follow_min_motion", True),
            ("frozen_motion", True),
        ):
            value = float(getattr(self, name))
            if not math.isfinite(value) or value < 0.0 or (strict and value == 0.0):
                raise ConfigurationError(
                    f"supervision.{name} must be a finite number {'>' if strict else '>='} 0, "
                    f"got {value!r}",
                    argument=f"supervision.{name}",
                )
        return replace(self, max_hold=float(hold))


class FollowWatch:
    """The following and frozen-encoder checks of one run (the module docstring).

    Call :meth:`observe` with each fresh joint reading, and :meth:`commanded` with each
    command sent; :meth:`observe` returns a one-sentence fault, or None.
    """

    def __init__(self, sup: Supervision) -> None:
        self.sup = sup
        self._cmd: FloatArray | None = None  # the command in force
        self._t_cmd = 0.0  # when it was sent (s)
        self._moved: FloatArray | None = None  # commanded displacement so far
        self._speed = 0.0  # norm of the command in force
        self._hist: deque[tuple[float, FloatArray, FloatArray, float]] = deque()
        self._same = 0  # consecutive identical readings
        self._same_from: FloatArray | None = None  # commanded displacement at the first one

    def commanded(self, qdot: FloatArray, t: float) -> None:
        """A command ``qdot`` (n,) was sent at loop time ``t`` (s)."""
        self._integrate(t)
        self._cmd, self._speed = np.array(qdot, dtype=float), float(np.linalg.norm(qdot))

    def _integrate(self, t: float) -> FloatArray:
        if self._moved is None or self._cmd is None:
            self._t_cmd = t
            return np.zeros(0) if self._moved is None else self._moved
        self._moved = self._moved + self._cmd * max(t - self._t_cmd, 0.0)
        self._t_cmd = t
        return self._moved

    def observe(self, q: FloatArray, t: float) -> str | None:
        """Judge the fresh reading ``q`` (n,) taken at loop time ``t`` (s)."""
        if self._moved is None:
            self._moved = np.zeros_like(q)
        moved = self._integrate(t)
        fault = self._frozen(q, moved)
        speed = max([self._speed] + [h[3] for h in self._hist])
        self._hist.append((t, q.copy(), moved.copy(), self._speed))
        while len(self._hist) > 1 and t - self._hist[1][0] >= self.sup.follow_window:
            self._hist.popleft()
        t_old, q_old, moved_old, _ = self._hist[0]
        if fault is not None or t - t_old < self.sup.follow_window:
            return fault
        want = moved - moved_old
        norm = float(np.linalg.norm(want))
        if norm < self.sup.follow_min_motion:
            return None
        miss = float(np.linalg.norm((q - q_old) - want))
        if miss <= self.sup.follow_tolerance * norm + self.sup.follow_lag * speed:
            return None
        return (
            f"the robot does not follow: over the last {t - t_old:.3f} s the joints moved "
            f"{np.linalg.norm(q - q_old):.4g} (m or rad, norm) for {norm:.4g} commanded, off by "
            f"{miss:.4g} > follow_tolerance·{norm:.4g} + follow_lag·{speed:.4g}"
        )

    def _frozen(self, q: FloatArray, moved: FloatArray) -> str | None:
        last = self._hist[-1][1] if self._hist else None
        if last is None or not np.array_equal(last, q):
            self._same, self._same_from = 1, moved.copy()
            return None
        self._same += 1
        assert self._same_from is not None
        drift = float(np.linalg.norm(moved - self._same_from))
        if self._same >= self.sup.frozen_cycles and drift >= self.sup.frozen_motion:
            return (
                f"frozen encoder: {self._same} consecutive fresh joint readings are identical "
                f"while the commands in force moved the joints by {drift:.4g} (m or rad, norm; "
                f"frozen_cycles {self.sup.frozen_cycles}, frozen_motion {self.sup.frozen_motion:g})"
            )
        return None
