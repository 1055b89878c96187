"""pytest plugin (``-p tests.compile_report``, ``make test``): the numba kernels the test
session compiled, i.e. what ``redservo warmup`` left out.

``make test`` warms the kernel cache before pytest starts its workers, so that the workers
load the kernels instead of each compiling them; a kernel compiled during the tests is a gap
of the warm-up, paid once per worker. Every process of the session (the pytest process or
each pytest-xdist worker) counts numba's ``numba:compile`` events (cache misses only) per test
and per kernel, and per test the kernel each compilation happened under (the outermost one
being compiled: e.g. ``measure_plan`` for numba's own overloads, ``impl``, compiled with it);
the workers hand their counts to the controller, and the summary prints the total with the
tests that compiled most, each with what it compiled (so a gap names the kernel the warm-up
lacks), then the kernels compiled most. Commands a test starts in a subprocess
are not counted.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Generator
from typing import Any

import pytest

TESTS: Counter[str] = Counter()
"""Compilations per test id (``(outside a test)``: collection, fixtures at teardown)."""
KERNELS: Counter[str] = Counter()
"""Compilations per kernel name."""
ROOTS: dict[str, Counter[str]] = {}
"""Per test id, compilations per outermost kernel being compiled (the kernel the test called)."""
_DEPTH: list[str] = []
"""The kernels being compiled now, outermost first."""
_CURRENT: list[str] = []
_LISTENING: list[bool] = []
_KEY = "redservo_compiles"
_TOP = 12
_ROOTS = 4


def _on_compile(event: Any) -> None:
    from redservo.bench.compile_progress import kernel_name

    test = _CURRENT[-1] if _CURRENT else "(outside a test)"
    name = kernel_name(event)
    TESTS[test] += 1
    KERNELS[name] += 1
    ROOTS.setdefault(test, Counter())[_DEPTH[0] if _DEPTH else name] += 1
    _DEPTH.append(name)


def _on_compiled(event: Any) -> None:
    if _DEPTH:
        _DEPTH.pop()


def pytest_configure(config: pytest.Config) -> None:
    from redservo.kernels import compiled

    if not compiled() or _LISTENING:
        return
    from numba.core import event

    class Listener(event.Listener):
        def on_start(self, ev: Any) -> None:
            _on_compile(ev)

        def on_end(self, ev: Any) -> None:
            _on_compiled(ev)

    event.register("numba:compile", Listener())
    _LISTENING.append(True)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: Any) -> Generator[None, None, None]:
    _CURRENT.append(item.nodeid)
    try:
        yield
    finally:
        _CURRENT.pop()


def pytest_sessionfinish(session: pytest.Session) -> None:
    out = getattr(session.config, "workeroutput", None)  # in an xdist worker
    if out is not None:
        out[_KEY] = json.dumps({"tests": TESTS, "kernels": KERNELS, "roots": ROOTS})


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: Any, error: Any) -> None:
    """In the xdist controller: add a worker's counts."""
    data = getattr(node, "workeroutput", {}).get(_KEY)
    if data:
        counts = json.loads(data)
        TESTS.update(counts["tests"])
        KERNELS.update(counts["kernels"])
        for test, roots in counts.get("roots", {}).items():
            ROOTS.setdefault(test, Counter()).update(roots)


def summary_lines() -> list[str]:
    """The summary: the total, then the tests and the kernels that compiled most."""
    total = sum(TESTS.values())
    if total == 0:
        return ["numba: no kernel compiled during the tests (the warm-up covered them)"]
    lines = [f"numba: {total} kernel compilation(s) during the tests (not warmed up); most in:"]
    lines += [f"  {n:4d}  {test}{_what(test)}" for test, n in TESTS.most_common(_TOP)]
    lines.append("kernels compiled most:")
    lines += [f"  {n:4d}  {name}" for name, n in KERNELS.most_common(_TOP)]
    return lines


def _what(test: str) -> str:
    """What ``test`` compiled: its outermost kernels with the compilations under each."""
    roots = ROOTS.get(test)
    if not roots:
        return ""
    top = roots.most_common(_ROOTS)
    more = ", ..." if len(roots) > _ROOTS else ""
    return ": " + ", ".join(f"{name} ({n})" for name, n in top) + more


def pytest_terminal_summary(terminalreporter: Any) -> None:
    for line in summary_lines():
        terminalreporter.write_line(line)
