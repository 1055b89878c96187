"""No silent stretch over 10 s in ``make test``: a pytest plugin, and a command wrapper.

As a command, ``python -m tests.heartbeat CMD ARGS...`` runs ``CMD`` and prints
``… mypy still running (20 s)`` every :data:`EVERY` seconds until it ends (the Makefile wraps
pip and mypy with it, which print nothing while they work); its exit code is ``CMD``'s.

As a pytest plugin for ``make test`` (``-p tests.heartbeat``):

``pytest -q`` prints a dot when a test ends, so a test that compiles the numba kernels, or
the collection of 2400 tests on two busy cores, can leave the terminal silent for a minute.
This plugin prints one line every :data:`EVERY` seconds while the collection or one test runs
on: ``… still running tests/test_x.py::test_y (20 s)``. It writes to a copy of the original
stderr taken when pytest loads it (before pytest captures the output of the tests), and it
changes nothing else: the tests themselves never see it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path
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


def run(cmd: list[str], every: float = EVERY) -> int:
    """Run ``cmd``, print a line every ``every`` s while it runs; return its exit code."""
    name, start = Path(cmd[0]).name, time.monotonic()
    proc = subprocess.Popen(cmd)
    while True:
        try:
            return proc.wait(timeout=every)
        except subprocess.TimeoutExpired:
            took = time.monotonic() - start
            print(f"  … {name} still running ({took:.0f} s)", file=sys.stderr, flush=True)
        except KeyboardInterrupt:  # the child got it too; wait for it to stop
            return proc.wait()


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("usage: python -m tests.heartbeat CMD [ARGS...]")
    sys.exit(run(sys.argv[1:]))
