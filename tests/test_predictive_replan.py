"""The predictive law's goal search among static obstacles (redservo.redundancy.predictive_replan;
docs/predictive.md, "Joint goal"): a new search takes what the seeds independent of ``q``
gave in the run's earlier searches from the memo (the same goal, fewer iterations), and a
search that found nothing new from where the arm still is defers the next one until the
arm moves. A run held at ``d_safe`` by a post (panda-posts sample 3, seed 0) restarted a
search of about 3 000 iterations every 150 periods from the same configuration; without
collision avoidance nothing changes (the obstacle-free campaigns stay byte for byte)."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest

from redservo.campaign.definition import load_campaign
from redservo.campaign.sampling import draw_built
from redservo.control.avoidance import check_collision
from redservo.redundancy import make_law
from redservo.redundancy.predictive import Predictive
from redservo.redundancy.predictive_distance import goal_clearance, static_scene
from redservo.redundancy.predictive_goal import GoalSearch
from redservo.redundancy.predictive_model import point_model
from redservo.redundancy.predictive_replan import HOLD, MOVED, Replan, SeedMemo


def _held() -> Any:
    """panda-posts sample 3 (seed 0): unreachable among the obstacles, held at d_safe."""
    return draw_built(load_campaign("panda-posts"), 0, 3)[1]


def _starts(exp: Any, monkeypatch: pytest.MonkeyPatch) -> tuple[Any, list, list]:
    """A predictive run with each search's ``(call, q)`` at its start and every law."""
    starts: list[tuple[int, np.ndarray]] = []
    laws: list[Predictive] = []
    start, compute = GoalSearch.start, Predictive.compute

    def spy_compute(self: Predictive, x: Any) -> Any:
        if not laws or laws[-1] is not self:
            laws.append(self)
        return compute(self, x)

    def spy_start(self: GoalSearch, model: Any, q: np.ndarray, *args: Any) -> None:
        starts.append((laws[-1]._calls, q.copy()))
        start(self, model, q, *args)

    monkeypatch.setattr(Predictive, "compute", spy_compute)
    monkeypatch.setattr(GoalSearch, "start", spy_start)
    return exp.run(method="predictive"), starts, laws


def test_a_held_run_does_not_restart_the_same_search(monkeypatch: pytest.MonkeyPatch) -> None:
    """The held run searches from its start, then once from where it is held (the arm has
    moved), and no more while it stays there: on main it restarted at periods 294 and 438
    from the configuration of period 150 (moved by 1e-7 of a range), for nothing."""
    exp = _held()
    res, starts, laws = _starts(exp, monkeypatch)
    span = exp.limits.q_max - exp.limits.q_min
    assert res.outcome == "max_iterations"
    assert float(np.min(res.log.min_distance)) >= exp.options.collision.d_safe - 1e-12
    assert len(starts) >= 2
    for (c0, q0), (c1, q1) in itertools.pairwise(starts):
        moved = float(np.max(np.abs(q1 - q0) / span))
        assert moved > MOVED or c1 - c0 >= HOLD * laws[-1].replan, (c0, c1, moved)
    assert laws[-1].replans.futile >= 1
    assert laws[-1]._memo.hits > 0  # the second search took the uniform seeds from the memo


def _model(exp: Any) -> Any:
    bMc, J = exp.robot.kinematics(exp.q0, check_limits=False)
    state = exp.task.evaluate(exp.scene, bMc, J, 0.0)
    return point_model(exp.robot, exp.task, state, exp.q0)


def _search(model: Any, q: np.ndarray, exp: Any, clear: Any, memo: Any) -> tuple[Any, int]:
    """A whole search: its result and its iterations."""
    lim = exp.limits
    span = lim.q_max - lim.q_min
    lo, hi = lim.q_min + 0.0102 * span, lim.q_max - 0.0102 * span
    search = GoalSearch(60)
    search.start(model, q, lo, hi, span, clear, memo)
    its, done, out = 0, False, None
    while not done:
        done, out = search.advance(None, steps=20)
        its += search.iterations
    return out, its


@pytest.mark.parametrize("sample", [3, 7])
def test_the_memo_gives_the_same_goal_with_fewer_iterations(sample: int) -> None:
    """A second search of the run, from a configuration moved a little, with the memo of
    the first: the result of the same search without the memo (to the last bits here: the
    same model and bounds), in fewer iterations; a changed model empties the memo."""
    exp = draw_built(load_campaign("panda-posts"), 0, sample)[1]
    law = make_law("predictive")
    check_collision(exp.options.collision, exp.robot, law)
    clear = goal_clearance(law)
    assert clear is not None and static_scene(law)
    model, memo = _model(exp), SeedMemo()
    _search(model, exp.q0, exp, clear, memo)
    q = exp.q0 + 0.02 * (exp.limits.q_max - exp.limits.q_min)
    fresh, its_fresh = _search(model, q, exp, clear, None)
    again, its_again = _search(model, q, exp, clear, memo)
    assert memo.hits > 0 and its_again < its_fresh
    assert (fresh is None) == (again is None)
    if fresh is not None:
        assert again[0] == fresh[0] and np.array_equal(again[1], fresh[1])
    moved = model._replace(P_b=model.P_b + 1e-3)
    hits = memo.hits
    _search(moved, q, exp, clear, memo)
    assert memo.hits == hits  # another target: nothing taken from the memo


def test_without_avoidance_neither_rule_holds() -> None:
    exp = _held()
    law = make_law("predictive")
    check_collision(None, exp.robot, law)
    assert goal_clearance(law) is None and not static_scene(law)


def test_a_futile_search_defers_the_next_until_the_arm_moves() -> None:
    q, span, key = np.zeros(3), np.ones(3), np.zeros(2)
    r = Replan(50)
    assert r.due(0, q, span, key)
    r.start(0, q, key, None)
    assert not r.due(49, q, span, key)
    r.end(60, q + 1e-7, span, key, None, defer=True)  # nothing new from the same place
    assert r.futile == 1
    assert not r.due(100, q, span, key)
    assert not r.due(60 + HOLD * 50 - 1, q + 0.5 * MOVED, span, key)
    assert r.due(100, q + 2 * MOVED, span, key)  # the arm moved: due again, count reset
    assert r.futile == 0
    # The cap: due again HOLD · replan after the end, then twice as long.
    r.start(100, q, key, None)
    r.end(120, q, span, key, None, defer=True)
    assert not r.due(120 + HOLD * 50 - 1, q, span, key) and r.due(120 + HOLD * 50, q, span, key)
    r.start(520, q, key, None)
    r.end(540, q, span, key, None, defer=True)
    assert r.futile == 2 and not r.due(540 + 2 * HOLD * 50 - 1, q, span, key)
    # The target moved: due again.
    assert r.due(600, q, span, key + 1.0)


@pytest.mark.parametrize(
    ("moved", "goal", "defer"),
    [(2 * MOVED, None, True), (0.0, np.ones(3), True), (0.0, None, False)],
)
def test_no_deferral_after_a_move_a_new_goal_or_without_avoidance(
    moved: float, goal: Any, defer: bool
) -> None:
    q, span, key = np.zeros(3), np.ones(3), np.zeros(2)
    r = Replan(50)
    r.start(0, q, key, None)
    r.end(60, q + moved, span, key, goal, defer=defer)
    assert r.futile == 0 and r.due(60, q + moved, span, key)
