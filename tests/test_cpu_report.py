"""tests/cpu_report.py: the CPU seconds of each test file, summed over the xdist workers."""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from collections.abc import Iterator
from types import SimpleNamespace

import pytest

from tests import cpu_report as cpu


@pytest.fixture
def sums(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Empty sums for the test (the session's own are put back after)."""
    monkeypatch.setattr(cpu, "CPU", Counter())
    monkeypatch.setattr(cpu, "TESTS", Counter())
    yield


def test_the_cpu_of_a_waited_for_subprocess_is_counted() -> None:
    """A test that runs a command in a subprocess pays its CPU there: it is counted."""
    before = cpu.cpu_seconds()
    spin = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.3: pass"
    subprocess.run([sys.executable, "-c", spin], check=True)
    assert cpu.cpu_seconds() - before >= 0.3


def test_worker_sums_add_up_per_file_in_the_summary(sums: None) -> None:
    for seconds, tests in (
        ({"tests/a.py": 2.0}, {"tests/a.py": 3}),
        ({"tests/a.py": 1.5, "tests/b.py": 9.0}, {"tests/a.py": 1, "tests/b.py": 2}),
    ):
        out = {"redservo_cpu": json.dumps({"cpu": seconds, "tests": tests})}
        cpu.pytest_testnodedown(SimpleNamespace(workeroutput=out), None)
    cpu.pytest_testnodedown(SimpleNamespace(workeroutput={}), None)  # a worker that crashed
    assert cpu.summary_lines() == [
        "CPU: 12 s in the tests (6 run); the files that took most:",
        "      9.0 s     2 tests  tests/b.py",
        "      3.5 s     4 tests  tests/a.py",
    ]


def test_a_session_without_tests_prints_nothing(sums: None) -> None:
    assert cpu.summary_lines() == []


def test_make_test_prints_the_cpu_of_each_test_file() -> None:
    from pathlib import Path

    makefile = (Path(__file__).resolve().parents[1] / "Makefile").read_text(encoding="utf-8")
    pytest_line = next(ln for ln in makefile.splitlines() if "-m pytest" in ln)
    assert "-p tests.cpu_report" in pytest_line
