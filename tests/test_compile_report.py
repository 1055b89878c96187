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
    monkeypatch.setattr(cr, "ROOTS", {})
    monkeypatch.setattr(cr, "_DEPTH", [])
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


@pytest.mark.skipif(not _compiled(), reason="counts numba's compilations")
def test_each_test_says_which_kernel_its_compilations_happened_under(
    counts: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A kernel compiled inside another one's compilation (a callee, numba's own overloads)
    counts under the outermost: the summary line of the test names what it called."""
    import numba

    cr.pytest_configure(None)  # type: ignore[arg-type]

    @numba.njit(cache=False)
    def inner_kernel(x: float) -> float:
        return x + 1.0

    @numba.njit(cache=False)
    def outer_kernel(x: float) -> float:
        return inner_kernel(x) * 2.0

    monkeypatch.setattr(cr, "_CURRENT", ["tests/test_x.py::test_z"])
    outer_kernel(1.0)
    assert cr.ROOTS == {"tests/test_x.py::test_z": Counter({"outer_kernel": 2})}
    assert cr._DEPTH == []
    assert cr.summary_lines()[1] == "     2  tests/test_x.py::test_z: outer_kernel (2)"


def test_worker_counts_add_up_in_the_summary(counts: None) -> None:
    for tests, kernels in (({"t::a": 2}, {"k1": 2}), ({"t::a": 1, "t::b": 4}, {"k2": 5})):
        out = {"redservo_compiles": json.dumps({"tests": tests, "kernels": kernels})}
        cr.pytest_testnodedown(SimpleNamespace(workeroutput=out), None)
    cr.pytest_testnodedown(SimpleNamespace(workeroutput={}), None)  # a worker that crashed
    lines = cr.summary_lines()
    assert lines[0].startswith("numba: 7 kernel compilation(s) during the tests")
    assert lines[1:3] == ["     4  t::b", "     3  t::a"]
    assert lines[3] == "kernels compiled most:" and lines[4:] == ["     5  k2", "     2  k1"]


def test_worker_roots_add_up_in_the_summary(counts: None) -> None:
    roots = ({"t::a": {"chain": 3}}, {"t::a": {"chain": 2, "other": 1}})
    for r in roots:
        out = {"redservo_compiles": json.dumps({"tests": {"t::a": 3}, "kernels": {}, "roots": r})}
        cr.pytest_testnodedown(SimpleNamespace(workeroutput=out), None)
    assert cr.summary_lines()[1] == "     6  t::a: chain (5), other (1)"


def test_no_compilation_says_the_warm_up_covered_the_tests(counts: None) -> None:
    assert cr.summary_lines() == [
        "numba: no kernel compiled during the tests (the warm-up covered them)"
    ]
