"""``redservo warmup`` runs what the commands (and so the tests) run: a kernel a command
compiles after a warm-up is a gap, paid by every test worker (tests/compile_report.py says
which test compiled what)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.bench import warmup_parts as wp


def test_the_reachability_part_among_obstacles_tests_the_goals_clearance(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A campaign among obstacles (panda-posts) checks each sample's goal for clearance
    (campaign/reach_obstacles.py: ``measure_plan``, compiled in the tests' first campaign
    among obstacles on main, 49 compilations); the warm-up's reachability part now tests it
    once, on the sample's start (a float64 (n,) array, as the search's seeds)."""
    import redservo.campaign.reach as reach
    import redservo.campaign.reach_obstacles as ro

    checked: list[Any] = []
    real = ro.goal_clearance

    def goal_clearance(exp: Any) -> Any:
        clear = real(exp)
        assert clear is not None  # the campaign has obstacles

        def spy(q: Any) -> bool:
            checked.append(q)
            return clear(q)

        return spy

    monkeypatch.setattr(reach, "goal_clearance", goal_clearance)
    monkeypatch.setattr(reach, "_compiled_search", lambda *a: None)  # not this test's part
    notes: list[str] = []
    wp.search("panda-posts", notes.append)
    assert notes == []
    assert len(checked) == 1
    q = checked[0]
    assert isinstance(q, np.ndarray) and q.dtype == np.float64 and q.ndim == 1
