"""tests/compile_report.py: the kernels the test session compiled (the warm-up's gaps)."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Iterator
from types import SimpleNamespace

import pytest

from tests import compile_report as cr


@pytest.fixture
def counts(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Empty counters for the test (the session's own are put back after)."""
    monkeypatch.setattr(cr, "TESTS", Counter())
    monkeypatch.setattr(cr, "KERNELS", Counter())
    yield


def _compiled() -> bool:
    from redservo.kernels import compiled

    return compiled()


@pytest.mark.skipif(not _compiled(), reason="counts numba's compilations")
def test_a_compilation_is_counted_for_the_running_test_and_its_kernel(
    counts: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    import numba

    cr.pytest_configure(None)  # type: ignore[arg-type]
    cr.pytest_configure(None)  # type: ignore[arg-type]  # one listener, not two

    @numba.njit(cache=False)
    def fresh_kernel(x: float) -> float:
        return x * 3.0

    monkeypatch.setattr(cr, "_CURRENT", ["tests/test_x.py::test_y"])
    fresh_kernel(1.0)
    assert cr.TESTS == Counter({"tests/test_x.py::test_y": 1})
    assert cr.KERNELS == Counter({"fresh_kernel": 1})


def test_worker_counts_add_up_in_the_summary(counts: None) -> None:
    for tests, kernels in (({"t::a": 2}, {"k1": 2}), ({"t::a": 1, "t::b": 4}, {"k2": 5})):
        out = {"redservo_compiles": json.dumps({"tests": tests, "kernels": kernels})}
        cr.pytest_testnodedown(SimpleNamespace(workeroutput=out), None)
    cr.pytest_testnodedown(SimpleNamespace(workeroutput={}), None)  # a worker that crashed
    lines = cr.summary_lines()
    assert lines[0].startswith("numba: 7 kernel compilation(s) during the tests")
    assert lines[1:3] == ["     4  t::b", "     3  t::a"]
    assert lines[3] == "kernels compiled most:" and lines[4:] == ["     5  k2", "     2  k1"]


def test_no_compilation_says_the_warm_up_covered_the_tests(counts: None) -> None:
    assert cr.summary_lines() == [
        "numba: no kernel compiled during the tests (the warm-up covered them)"
    ]
