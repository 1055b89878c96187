"""What a run on hardware asks of the operating system and of the interpreter, for the
loop's period to hold on a busy machine.

* :func:`realtime_scheduling`: the loop's thread under ``SCHED_FIFO`` at ``priority``
  (1-99; ros2_control's controller manager asks for 50), so no ordinary process delays its
  wake-up; the helper threads it is given (the camera's tracker) one level below, so an
  ordinary process cannot preempt them while they hold the GIL the loop waits for. It needs the privilege (root, ``CAP_SYS_NICE`` or an ``rtprio`` limit in
  ``/etc/security/limits.conf``, as the Franka and UR set-ups configure); refused, the
  loop runs under the ordinary policy and the context manager says so (``timing.json``'s
  ``scheduling``, and a :class:`RuntimeWarning`): never silently. Linux's real-time
  throttling (5 % of each second kept for other tasks) still applies.
* :func:`quiet_interpreter`: the objects alive at the start are frozen out of the garbage
  collector (a collection then walks only what the run allocates) and the thread switch
  interval drops to 0.5 ms, so a thread holding the GIL (the camera's tracker) makes the
  loop wait at most that long.

Both restore the previous settings at the end of the ``with`` block.

Units: seconds.
"""

from __future__ import annotations

import gc
import os
import sys
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from redservo.errors import ConfigurationError

__all__ = ["SWITCH_INTERVAL", "quiet_interpreter", "realtime_scheduling"]

SWITCH_INTERVAL = 0.0005
"""The interpreter's thread switch interval during a run (s)."""


@contextmanager
def quiet_interpreter(switch_interval: float = SWITCH_INTERVAL) -> Iterator[None]:
    """For the ``with`` block: collect, freeze the surviving objects out of the garbage
    collector, and switch threads every ``switch_interval`` s."""
    old = sys.getswitchinterval()
    gc.collect()
    gc.freeze()
    sys.setswitchinterval(switch_interval)
    try:
        yield
    finally:
        sys.setswitchinterval(old)
        gc.unfreeze()


def _set(tid: int, policy: int, param: os.sched_param) -> None:
    try:
        os.sched_setscheduler(tid, policy, param)
    except ProcessLookupError:  # a helper thread that has ended
        pass


@contextmanager
def realtime_scheduling(priority: int, helpers: Sequence[int] = ()) -> Iterator[str]:
    """Run the calling thread under ``SCHED_FIFO`` at ``priority`` and the threads
    ``helpers`` at ``priority - 1`` (at least 1) for the ``with`` block; yield what was
    granted (e.g. ``"SCHED_FIFO 50"``, or why it is ``"SCHED_OTHER"``).

    Args:
        priority: 1-99, or 0 not to ask.
        helpers: Native thread ids (``threading.Thread.native_id``).

    Raises:
        ConfigurationError: ``priority`` is not an integer 0-99.
    """
    if isinstance(priority, bool) or not isinstance(priority, int) or not 0 <= priority <= 99:
        raise ConfigurationError(
            f"realtime_priority must be an integer 0-99 (0: do not ask), got {priority!r}",
            argument="realtime_priority",
        )
    if priority == 0 or not hasattr(os, "sched_setscheduler"):
        yield "SCHED_OTHER (not asked)" if priority == 0 else "SCHED_OTHER (not on this system)"
        return
    tids = [0, *helpers]
    old = [(os.sched_getscheduler(t), os.sched_getparam(t)) for t in tids]
    try:
        for tid, prio in zip(tids, [priority] + [max(priority - 1, 1)] * len(helpers)):
            _set(tid, os.SCHED_FIFO, os.sched_param(prio))
    except OSError as exc:
        for tid, (policy, param) in zip(tids, old):
            _set(tid, policy, param)
        why = f"SCHED_OTHER (SCHED_FIFO {priority} refused: {exc.strerror})"
        warnings.warn(
            f"the servo loop runs without real-time scheduling: {why}; its period may jitter "
            "on a busy machine (docs/real-robot.md, real-time scheduling)",
            RuntimeWarning,
            stacklevel=3,
        )
        yield why
        return
    try:
        yield f"SCHED_FIFO {priority}" + (f" (helpers {max(priority - 1, 1)})" if helpers else "")
    finally:
        for tid, (policy, param) in zip(tids, old):
            _set(tid, policy, param)
