"""A pytest plugin for ``make test`` (``-p tests.heartbeat``): no silent stretch over 10 s.

``pytest -q`` prints a dot when a test ends, so a test that compiles the numba kernels, or
the collection of 2400 tests on two busy cores, can leave the terminal silent for a minute.
This plugin prints one line every :data:`EVERY` seconds while the collection or one test runs
on: ``… still running tests/test_x.py::test_y (20 s)``. It writes to a copy of the original
stderr taken when pytest loads it (before pytest captures the output of the tests), and it
changes nothing else: the tests themselves never see it.
"""

from __future__ import annotations

import os
import threading
import time
from typing import Any

EVERY = 10.0
"""Seconds between two lines while one step runs."""

try:
    _OUT: int | None = os.dup(2)
except OSError:  # pragma: no cover - no stderr
    _OUT = None
_lock = threading.Lock()
_state: dict[str, Any] = {"what": "collecting the tests", "since": time.monotonic()}
_stop = threading.Event()


def _set(what: str | None) -> None:
    with _lock:
        _state["what"], _state["since"] = what, time.monotonic()


def line(now: float) -> str | None:
    """The line to print at time ``now`` (``time.monotonic``), or None when nothing runs."""
    with _lock:
        what, since = _state["what"], _state["since"]
    return f"\n  … {what} ({now - since:.0f} s)\n" if what else None


def _beat() -> None:
    while not _stop.wait(EVERY):
        text = line(time.monotonic())
        if text and _OUT is not None:
            try:
                os.write(_OUT, text.encode("utf-8", "replace"))
            except OSError:  # pragma: no cover - stderr closed
                return


def pytest_configure(config: Any) -> None:
    threading.Thread(target=_beat, daemon=True, name="pytest-heartbeat").start()


def pytest_collection_finish(session: Any) -> None:
    _set(None)


def pytest_runtest_logstart(nodeid: str, location: Any) -> None:
    _set(f"still running {nodeid}")


def pytest_runtest_logfinish(nodeid: str, location: Any) -> None:
    _set(None)


def pytest_unconfigure(config: Any) -> None:
    _stop.set()
