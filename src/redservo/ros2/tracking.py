"""Tracking off the control loop's thread: a worker decodes and measures each newest frame,
the loop takes the latest result without waiting.

:class:`FrameWorker` waits on a DDS reader (a Cyclone ``WaitSet``: the wait blocks in C,
the loop's thread keeps the interpreter), takes every sample that arrived, keeps the newest
(the older ones are counted in :attr:`FrameWorker.skipped`, never dropped silently) and
hands it to ``process``, whose result (a measurement stamped with the *frame's* stamp, or
None) replaces the previous one under a lock: a latest-value handoff. A slow frame delays
only the next measurement, never an iteration of the loop; the loop's freshness checks see
the measurement's stamp, so a tracker that falls behind ends the run ``stale_measurement``
as a silent camera would.

What ``process`` raises (e.g. a :class:`~redservo.ros2.faults.MessageError` for an image of
the wrong size) stops the worker and is re-raised by :meth:`FrameWorker.latest` on the
loop's thread, where the loop stops the arm.

Units: seconds.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Generic, TypeVar

from cyclonedds.core import (
    GuardCondition,
    InstanceState,
    ReadCondition,
    SampleState,
    ViewState,
    WaitSet,
)
from cyclonedds.util import duration

__all__ = ["FrameWorker"]

T = TypeVar("T")

_WAKE = duration(milliseconds=200)
"""The longest wait before the worker checks for close() (s, as DDS nanoseconds)."""


class FrameWorker(Generic[T]):
    """Measure the newest sample of ``reader`` in a thread (module docstring).

    Args:
        participant: The DDS participant of ``reader`` (for the wait set).
        reader: A DDS reader of ``cls`` samples.
        cls: The sample type; other samples (instance-state notifications) are ignored.
        process: The measurement of one sample (None: nothing measured in it); called on
            the worker's thread only.
        name: The thread's name.
    """

    def __init__(
        self,
        participant: Any,
        reader: Any,
        cls: type,
        process: Callable[[Any], T | None],
        name: str = "redservo-tracking",
    ) -> None:
        self.reader, self.cls, self.process = reader, cls, process
        self._lock = threading.Lock()
        self._value: T | None = None
        self._error: BaseException | None = None
        self.frames = 0
        """Samples processed."""
        self.skipped = 0
        """Samples not processed because a newer one had arrived with them."""
        self.busy = threading.Event()
        """Set while ``process`` runs (tests wait on it)."""
        self._closing = False
        self._guard = GuardCondition(participant)
        self._waitset = WaitSet(participant)
        mask = SampleState.NotRead | ViewState.Any | InstanceState.Any
        self._waitset.attach(ReadCondition(reader, mask))
        self._waitset.attach(self._guard)
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _newest(self) -> Any:
        newest, count = None, 0
        for sample in self.reader.take(N=64):
            if isinstance(sample, self.cls):
                newest, count = sample, count + 1
        if count > 1:
            self.skipped += count - 1
        return newest

    def _run(self) -> None:
        while not self._closing:
            self._waitset.wait(_WAKE)
            if self._closing:
                return
            sample = self._newest()
            if sample is None:
                continue
            self.busy.set()
            try:
                value = self.process(sample)
            except BaseException as exc:  # handed to the loop's thread by latest()
                with self._lock:
                    self._error = exc
                return
            finally:
                self.busy.clear()
            with self._lock:
                self.frames += 1
                if value is not None:
                    self._value = value

    def latest(self) -> T | None:
        """The newest measurement (None before the first); never waits for a frame.

        Raises:
            Exception: what ``process`` raised (the worker has stopped).
        """
        with self._lock:
            if self._error is not None:
                raise self._error
            return self._value

    @property
    def native_id(self) -> int | None:
        """The worker's native thread id (for its scheduling)."""
        return self._thread.native_id

    @property
    def alive(self) -> bool:
        """True while the worker runs (False after an error or :meth:`close`)."""
        return self._thread.is_alive()

    def close(self, timeout: float = 2.0) -> None:
        """Stop the worker and wait up to ``timeout`` (s) for it (safe to call twice)."""
        self._closing = True
        self._guard.set(True)
        if self._thread is not threading.current_thread():
            self._thread.join(timeout)
