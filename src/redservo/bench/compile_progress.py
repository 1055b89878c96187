"""Progress of the numba compilations of a first run, at least every 10 s.

On an empty kernel cache a command compiles tens of kernels for one to two minutes on a busy
2-core machine (docs/speed.md). :class:`Progress` counts the compilations numba reports (its
``numba:compile`` event: cache misses only) and, while they go on, prints one line every
:data:`EVERY` seconds on stderr saying which group compiles, how many kernels are done out of
how many expected, the elapsed time and an estimate of what is left, e.g.::

    redservo: compiling [run] 104/~220 kernels, 50 s elapsed, about 56 s left (now: gradient)

The expected counts (:data:`EXPECTED`) were measured on an empty cache; a command without a
measurement is bounded by the whole warm-up (every command compiles a subset of it). When
nothing has compiled for :data:`EVERY` seconds the reporter prints one closing line and goes
quiet until the next compilation. The clock is injectable (tests use a fake one) and
:meth:`Progress.tick` is what the background ticker calls, so it can be driven by hand.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from typing import IO, Any

__all__ = ["EVERY", "EXPECTED", "Progress", "expected_for", "kernel_name"]

EVERY = 8.0
"""Seconds between two progress lines while kernels compile: 8, so that a ticker held back
by a compilation that keeps the interpreter lock (2 s late, seen on a loaded machine) still
speaks within 10 s."""

EXPECTED: dict[str, int] = {
    "laws": 150,
    "scenarios": 102,
    "compiled steps": 4,
    "reachability": 174,
    "campaign loop": 132,
    "run": 220,
}
"""Kernel compilations (numba cache misses) of each warm-up group and of ``redservo run
panda-4points`` (used for every ``redservo run``: other scenarios compile a similar set),
measured on an empty cache (``NUMBA_CACHE_DIR=$(mktemp -d)``, numba 0.68; the warm-up's
groups in the order ``redservo warmup --jobs 2`` runs them from a fresh clone, 2026-11-29)."""

_WARMUP = ("laws", "scenarios", "compiled steps", "reachability", "campaign loop")


def expected_for(group: str) -> tuple[int, bool]:
    """The expected number of compilations of ``group`` and whether it is only an upper
    bound (the whole warm-up, for a command never measured)."""
    if EXPECTED.get(group):
        return EXPECTED[group], False
    return sum(EXPECTED[g] for g in _WARMUP), True


def kernel_name(event: Any) -> str:
    """The name of the function a numba ``numba:compile`` event is about (``?`` if unknown)."""
    data = getattr(event, "data", None) or {}
    dispatcher = data.get("dispatcher") if isinstance(data, dict) else None
    func = getattr(dispatcher, "py_func", None)
    return str(getattr(func, "__name__", "?"))


class Progress:
    """Counts compilations per group and says how far along they are (module docstring).

    ``clock`` returns seconds (default ``time.monotonic``); ``stream`` defaults to
    ``sys.stderr`` at the time of each line; ``ticker=False`` starts no background thread
    (the caller calls :meth:`tick`)."""

    def __init__(
        self,
        group: str = "run",
        *,
        stream: IO[str] | None = None,
        clock: Callable[[], float] = time.monotonic,
        every: float = EVERY,
        ticker: bool = True,
    ) -> None:
        self._stream, self._clock, self.every, self._ticker = stream, clock, every, ticker
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self.count, self.depth = 0, 0
        self.set_group(group)

    def set_group(self, group: str, expected: int | None = None) -> None:
        """Start counting a new group (``expected``: its count, default :func:`expected_for`)."""
        with self._lock:
            self.group, self.done, self.current = group, 0, ""
            self.expected, self.bound = (
                (expected, False) if expected is not None else expected_for(group)
            )
            self.started: float | None = None
            self.last: float | None = None
            self._stopped, self._talked = False, False

    def on_start(self, name: str) -> None:
        """A kernel named ``name`` starts compiling."""
        with self._lock:
            now = self._clock()
            self.started = now if self.started is None else self.started
            self.current = name if not self.depth else self.current  # the outermost kernel
            self.last, self.depth = now, self.depth + 1
        if self._ticker and (self._thread is None or not self._thread.is_alive()):
            self._thread = threading.Thread(target=self._run, daemon=True, name="compile-progress")
            self._thread.start()

    def on_end(self) -> None:
        """The kernel being compiled is done."""
        with self._lock:
            self.done, self.count = self.done + 1, self.count + 1
            self.depth = max(self.depth - 1, 0)
            self.last = self._clock()

    def line(self) -> str:
        """The progress line now: group, count done/expected, elapsed, estimate."""
        with self._lock:
            now, done, expected = self._clock(), self.done, self.expected
            elapsed = 0.0 if self.started is None else now - self.started
            of = f"{'≤' if self.bound else '~'}{expected}" if expected else "?"
            text = (
                f"redservo: compiling [{self.group}] {done}/{of} kernels, {elapsed:.0f} s elapsed"
            )
            if done and expected > done:
                text += f", about {elapsed / done * (expected - done):.0f} s left"
            elif expected and done >= expected:
                text += ", more than expected: estimate unknown"
            return text + (f" (now: {self.current})" if self.depth else "")

    def tick(self) -> bool:
        """Print the progress line; when nothing compiled for :attr:`every` seconds print a
        closing line instead and return False (the ticker then stops). Silent, and False,
        after :meth:`finish`."""
        with self._lock:
            if self._stopped:
                return False
            idle = not self.depth and (self.last is None or self._clock() - self.last >= self.every)
            if idle and self.started is None:  # a ticker left from the previous command
                return False  # nothing of this group compiled: nothing to say
            summary = f"redservo: compiled {self.done} kernel(s) [{self.group}]; running"
        text = summary if idle else self.line()
        with self._lock:  # a line is never printed after finish() returned
            if self._stopped:
                return False
            self._talked = not idle  # a progress line, not yet closed
            self._say(text)
        return not idle

    def finish(self) -> None:
        """The command is over: stop the ticker (no line of this command's compilations
        appears during the next one), saying the closing line now if a progress line was
        printed and none closed it."""
        with self._lock:
            if self._stopped:
                return
            self._stopped = True
            if self._talked:
                self._say(f"redservo: compiled {self.done} kernel(s) [{self.group}]; running")

    def _say(self, text: str) -> None:
        print(text, file=self._stream or sys.stderr, flush=True)

    def _run(self) -> None:
        stop = threading.Event()
        while not stop.wait(self.every):
            if not self.tick():
                return
