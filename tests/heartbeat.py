"""No silent stretch over 10 s in ``make test``: a pytest plugin, and a command wrapper.

As a command, ``python -m tests.heartbeat CMD ARGS...`` runs ``CMD`` and prints
``… mypy still running (20 s)`` every :data:`EVERY` seconds until it ends (the Makefile wraps
pip and mypy with it, which print nothing while they work); its exit code is ``CMD``'s.

As a pytest plugin for ``make test`` (``-p tests.heartbeat``):

``pytest -q`` prints a dot when a test ends, so a test that compiles the numba kernels, or
the collection of 2400 tests on two busy cores, can leave the terminal silent for a minute.
Once the terminal has been silent for :data:`EVERY` seconds (no dot), this plugin prints a line
for the collection, or for each test running: ``… still running tests/test_x.py::test_y (20 s)``.
Under pytest-xdist (``-n 2``) it talks in the controller only, which hears when each worker's
tests start and end, so the two tests running give two lines. It writes to a copy of the original stderr taken when pytest
loads it (before pytest captures the output of the tests), and it changes nothing else: the
tests themselves never see it.
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
"""Seconds of silence after which the plugin (and the command wrapper) prints a line."""

TICK = 1.0
"""Seconds between two looks of the plugin at the terminal's silence."""

try:
    _OUT: int | None = os.dup(2)
except OSError:  # pragma: no cover - no stderr
    _OUT = None
_lock = threading.Lock()
_state: dict[str, Any] = {"collecting": time.monotonic(), "running": {}, "quiet": time.monotonic()}
"""``collecting``: monotonic start of the collection, or None once a test started;
``running``: ``{nodeid: monotonic start}`` of the tests running now (two under pytest-xdist,
whose controller hears every worker's test start and end); ``quiet``: when the terminal last
got a dot (a test ended) or a line."""
_stop = threading.Event()


def line(now: float) -> str | None:
    """What to print at time ``now`` (``time.monotonic``): once the terminal has been silent for
    :data:`EVERY` s, one line for the collection while it runs and one per running test, with
    how long each has run; None while it is not silent that long or nothing runs."""
    with _lock:
        collecting, running, quiet = _state["collecting"], dict(_state["running"]), _state["quiet"]
    if now - quiet < EVERY:
        return None
    items = [] if collecting is None else [("collecting the tests", collecting)]
    items += [(f"still running {nodeid}", since) for nodeid, since in running.items()]
    return "".join(f"\n  … {what} ({now - since:.0f} s)\n" for what, since in items) or None


def _beat() -> None:
    while not _stop.wait(TICK):
        now = time.monotonic()
        text = line(now)
        if text and _OUT is not None:
            with _lock:
                _state["quiet"] = now
            try:
                os.write(_OUT, text.encode("utf-8", "replace"))
            except OSError:  # pragma: no cover - stderr closed
                return


def pytest_configure(config: Any) -> None:
    # An xdist worker's stderr is not the terminal; the controller hears its tests.
    if not hasattr(config, "workerinput"):
        threading.Thread(target=_beat, daemon=True, name="pytest-heartbeat").start()


def pytest_collection_finish(session: Any) -> None:
    with _lock:
        _state["collecting"] = None


def pytest_runtest_logstart(nodeid: str, location: Any) -> None:
    with _lock:
        _state["collecting"] = None
        _state["running"][nodeid] = time.monotonic()


def pytest_runtest_logfinish(nodeid: str, location: Any) -> None:
    with _lock:
        _state["running"].pop(nodeid, None)
        _state["quiet"] = time.monotonic()  # pytest prints the test's dot


def pytest_runtest_logreport(report: Any) -> None:
    if report.when not in ("setup", "call"):  # teardown, or xdist's report of a crashed worker
        pytest_runtest_logfinish(report.nodeid, None)


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
