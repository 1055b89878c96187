"""pytest plugin (``-p tests.cpu_report``, ``make test``): the CPU seconds of each test file.

``--durations`` gives wall seconds, which on the shared 2-core machine say more about the
load than about a test (a test that waits for a subprocess, a port or a timeout costs wall
time, not CPU). The figure that adds up to ``make test``'s CPU time is each test's CPU:
every process of the session (the pytest process or each pytest-xdist worker) adds, per
test file, the CPU seconds (user + system) its tests took, in the process itself and in the
subprocesses they started and waited for; the workers hand their sums to the controller,
and the summary prints the total and the files that took most, with their test counts.
"""

from __future__ import annotations

import json
import os
import resource
from collections import Counter
from collections.abc import Generator
from typing import Any

import pytest

CPU: Counter[str] = Counter()
"""CPU seconds per test file (this process and its waited-for subprocesses)."""
TESTS: Counter[str] = Counter()
"""Tests run per test file."""
_KEY = "redservo_cpu"
_TOP = 25


def cpu_seconds() -> float:
    """User + system CPU seconds of this process and of its finished, waited-for children."""
    own = os.times()
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.user + own.system + kids.ru_utime + kids.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: Any) -> Generator[None, None, None]:
    start = cpu_seconds()
    try:
        yield
    finally:
        name = item.nodeid.split("::", 1)[0]
        CPU[name] += cpu_seconds() - start
        TESTS[name] += 1


def pytest_sessionfinish(session: pytest.Session) -> None:
    out = getattr(session.config, "workeroutput", None)  # in an xdist worker
    if out is not None:
        out[_KEY] = json.dumps({"cpu": CPU, "tests": TESTS})


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: Any, error: Any) -> None:
    """In the xdist controller: add a worker's sums."""
    data = getattr(node, "workeroutput", {}).get(_KEY)
    if data:
        counts = json.loads(data)
        CPU.update(counts["cpu"])
        TESTS.update(counts["tests"])


def summary_lines() -> list[str]:
    """The total, then the test files that took the most CPU."""
    if not CPU:
        return []
    total = sum(CPU.values())
    lines = [
        f"CPU: {total:.0f} s in the tests ({sum(TESTS.values())} run); the files that took most:"
    ]
    for name, seconds in CPU.most_common(_TOP):
        lines.append(f"  {seconds:7.1f} s  {TESTS[name]:4d} tests  {name}")
    return lines


def pytest_terminal_summary(terminalreporter: Any) -> None:
    for line in summary_lines():
        terminalreporter.write_line(line)
