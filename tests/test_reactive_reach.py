"""benchmarks/reactive_reach.py: the reachable samples split by whether the goal is reachable
from the start alone (docs/results.md, "Why the reactive laws stop near 70 %")."""

from __future__ import annotations

from types import ModuleType

import pytest

from tests.load_module import load_module


def _bench() -> ModuleType:
    return load_module("benchmarks/reactive_reach.py")


def _row(sample: int, method: str, reachable: str, success: str, outcome: str) -> dict[str, str]:
    return {
        "sample": str(sample),
        "method": method,
        "reachable": reachable,
        "success": success,
        "outcome": outcome,
    }


ROWS = [
    _row(0, "qp", "True", "True", "converged"),
    _row(1, "qp", "True", "False", "max_iterations"),
    _row(2, "qp", "True", "False", "max_iterations"),
    _row(3, "qp", "False", "False", "max_iterations"),
    _row(0, "sns", "True", "False", "target_lost"),
    _row(1, "sns", "True", "True", "converged"),
    _row(2, "sns", "True", "False", "max_iterations"),
]


def test_split_counts_successes_among_locally_reachable_and_other_samples() -> None:
    bench = _bench()
    got = bench.split(ROWS, {0: True, 1: True, 2: False})
    assert got["qp"] == bench.Split((1, 3), (1, 2), (0, 1))
    assert got["sns"] == bench.Split((1, 3), (1, 2), (0, 1))
    lines = bench.split_lines(got)
    assert lines[2] == "| qp | 1/3 = 33.3 % | 1/2 = 50.0 % | 0/1 = 0.0 % |"


def test_split_names_a_reachable_sample_without_a_verdict() -> None:
    with pytest.raises(KeyError, match="sample 2"):
        _bench().split(ROWS, {0: True, 1: True})


def test_runs_at_the_cap_are_slow_when_a_longer_cap_converges_them() -> None:
    long_rows = [
        _row(1, "qp", "True", "True", "converged"),
        _row(2, "qp", "True", "False", "max_iterations"),
        _row(3, "qp", "False", "False", "converged"),
        _row(2, "sns", "True", "False", "max_iterations"),
    ]
    assert _bench().slow_or_stalled(ROWS, long_rows) == {"qp": (1, 1), "sns": (0, 1)}


def test_start_reachable_on_two_panda_samples() -> None:
    """Sample 0 of panda-near-limits is reached by the search from its start; sample 13's
    goal only from other seeds (qp stalls there with joints 2, 3 and 7 at their margin)."""
    from redservo.campaign.definition import load_campaign
    from redservo.campaign.reach import reachable
    from redservo.campaign.sampling import draw_sample
    from redservo.experiment.build import build

    bench = _bench()
    defn = load_campaign("panda-near-limits")
    exps = [build(draw_sample(defn, 0, i).scenario) for i in (0, 13)]
    assert [reachable(e) for e in exps] == [True, True]
    assert [bench.start_reachable(e) for e in exps] == [True, False]
