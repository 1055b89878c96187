"""The rate bridge: a vision loop at 10-30 Hz, an arm's controller at 500 Hz-1 kHz.

:class:`RateBridge` wraps a robot interface: the servo loop's command becomes a *target*,
and a thread publishes at ``rate`` Hz a command that moves toward it by at most
``qddot_max / rate`` per publication (rad/s per tick): no velocity step at each camera frame,
the acceleration limit kept between control periods. A target not renewed for
``hold_timeout`` seconds is dropped (the target becomes zero, reached within the
acceleration limit): a held command never outlives the loop's ``watchdog_timeout``, even if
the loop's thread hangs. :meth:`RateBridge.stop` ramps to zero within the acceleration limit
and then stops the robot. Without ``qddot_max`` the command follows the target at once.

The ramp counts whole ticks of ``1 / rate`` seconds whatever the thread's lateness: a late
tick moves less, never more. :meth:`RateBridge.tick` is the step itself (deterministic, for
tests with a virtual clock).

Units: seconds, rad/s, rad/s², Hz.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_vector
from redservo.errors import ConfigurationError

__all__ = ["RateBridge"]


class RateBridge:
    """Publish a robot's velocity command at a higher rate, ramped (module docstring).

    Args:
        robot: The robot interface commands are published to (its ``send_velocity``).
        n: Number of joints.
        rate: Publication rate (Hz), in [1, 2000].
        qddot_max: (n,) acceleration limits (rad/s²), or None (no ramp).
        hold_timeout: Drop a target not renewed for this long (s), > 0.
        clock: Monotonic clock (s).
        start: Start the publishing thread now (False: call :meth:`tick` yourself).

    Raises:
        ConfigurationError: a rate, limit or timeout out of range.
    """

    def __init__(
        self,
        robot: Any,
        n: int,
        *,
        rate: float,
        qddot_max: ArrayLike | None,
        hold_timeout: float,
        clock: Callable[[], float] = time.monotonic,
        start: bool = True,
    ) -> None:
        if not (math.isfinite(rate) and 1.0 <= rate <= 2000.0):
            raise ConfigurationError(
                f"publish_rate must be 1-2000 Hz, got {rate!r}", argument="publish_rate"
            )
        if not (math.isfinite(hold_timeout) and hold_timeout > 0.0):
            raise ConfigurationError(
                f"hold_timeout must be > 0 s, got {hold_timeout!r}", argument="hold_timeout"
            )
        self.robot, self.n, self.rate = robot, n, float(rate)
        self.step = None if qddot_max is None else as_vector(qddot_max, "qddot_max", n) / rate
        if self.step is not None and not np.all(self.step > 0.0):
            raise ConfigurationError("qddot_max must be > 0 rad/s²", argument="qddot_max")
        self.hold_timeout, self.clock = float(hold_timeout), clock
        self.command = np.zeros(n)
        """The command published last (rad/s)."""
        self._target, self._t_target = np.zeros(n), -math.inf
        self._lock = threading.Lock()
        self._halt = threading.Event()
        self.published = 0
        self._thread: threading.Thread | None = None
        if start:
            self._thread = threading.Thread(target=self._run, name="rate-bridge", daemon=True)
            self._thread.start()

    # -- the robot interface --------------------------------------------------------------------

    def read_joints(self) -> tuple[float, FloatArray]:
        """The wrapped robot's reading."""
        t, q = self.robot.read_joints()
        return t, q

    def send_velocity(self, qdot: ArrayLike) -> None:
        """Set the target (n,) joint velocities (rad/s), valid for ``hold_timeout``."""
        v = as_vector(qdot, "qdot", self.n)
        with self._lock:
            self._target, self._t_target = v.copy(), self.clock()

    def tick(self, now: float) -> FloatArray:
        """Publish the next command at time ``now`` (s) and return it (rad/s)."""
        with self._lock:
            fresh = now - self._t_target <= self.hold_timeout
            target = self._target if fresh else np.zeros(self.n)
        change = target - self.command
        if self.step is not None:
            change = np.clip(change, -self.step, self.step)
        self.command = self.command + change
        if np.all(self.command == target):
            self.command = target.copy()  # exact arrival (no rounding residue)
        self.robot.send_velocity(self.command)
        self.published += 1
        return self.command

    def _run(self) -> None:
        period, next_tick = 1.0 / self.rate, self.clock()
        while not self._halt.is_set():
            self.tick(self.clock())
            next_tick = max(next_tick + period, self.clock())
            self._halt.wait(max(next_tick - self.clock(), 0.0))

    def stop(self) -> None:
        """Ramp to zero within the acceleration limit, then stop the robot (safe twice)."""
        self._halt.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=1.0)
        with self._lock:
            self._target, self._t_target = np.zeros(self.n), -math.inf
        limit = 1 + int(np.max(np.abs(self.command) / self.step)) if self.step is not None else 1
        for _ in range(min(limit, int(self.rate * 5))):  # at most 5 s of ramp
            if not np.any(self.command):
                break
            self.tick(self.clock())
            time.sleep(1.0 / self.rate)
        self.command = np.zeros(self.n)
        self.robot.stop()

    def close(self) -> None:
        """Stop the thread (the arm ramped to zero) and close the wrapped robot."""
        if not self._halt.is_set() or np.any(self.command):
            self.stop()
        close = getattr(self.robot, "close", None)
        if close is not None:
            close()
