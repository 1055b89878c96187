"""The predictive law's joint-goal search spread over periods (docs/predictive.md, "Joint
goal"): its two stages run in turn and the law takes the goal met so far, so that a goal only
the feature stage finds (mc05-joint-limits: the desired camera pose beyond the bounds, its
pose IK failing from all 67 seeds) is set in the first periods, not after ~3 000 iterations
(150 periods at ``goal_steps = 20``); the search's result is the one of the stages run one
after the other; and the campaign's rows do not depend on the machine's clock."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from redservo import make_law
from redservo.campaign.definition import load_campaign
from redservo.campaign.sampling import draw_sample
from redservo.experiment.build import build
from redservo.redundancy.predictive_goal import (
    TOL,
    GoalSearch,
    Met,
    _feature_stage,
    _pose_stage,
    camera_goal,
    goal_error,
    nearest_goal,
)
from redservo.redundancy.predictive_model import point_model
from redservo.simulation import simulate
from redservo.simulation.options import SimulationOptions

MC05_SAMPLE = 7
"""mc05-joint-limits (seed 0) sample 7: its goal is met only by the feature stage (48
iterations to converge with the whole search in one step, 181 with it spread over periods
before the stages ran in turn)."""


def _mc05_law(periods: int, **options: Any) -> tuple[Any, Any]:
    exp = build(draw_sample(load_campaign("mc05-joint-limits"), 0, MC05_SAMPLE).scenario)
    law: Any = make_law("predictive", **options)
    opts = SimulationOptions(**{**exp.options.__dict__, "max_iterations": periods})
    res = simulate(
        exp.robot,
        exp.scene,
        exp.task,
        law,
        exp.q0,
        options=opts,
        camera=exp.camera,
        limits=exp.limits,
    )
    return law, res


def test_a_goal_only_the_feature_stage_finds_is_set_in_the_first_periods() -> None:
    """After 8 periods of 20 search iterations the law has an exact goal while the search
    still runs (its pose stage alone takes ~3 000 iterations: the goal came at period 154;
    at period 3 with the stages one for one, 6 with the pose stage's share of 3)."""
    law, _ = _mc05_law(8)
    assert law._search.running
    assert law._goal is not None and law.last_model is not None
    assert goal_error(law.last_model, law._goal) < TOL


def _panda_search(i: int) -> tuple[Any, ...]:
    exp = build(draw_sample(load_campaign("panda-near-limits"), 0, i).scenario)
    bMc, J = exp.robot.kinematics(exp.q0, check_limits=False)
    model = point_model(exp.robot, exp.task, exp.task.evaluate(exp.scene, bMc, J, 0.0), exp.q0)
    lim = exp.limits
    band = 0.0102 * (lim.q_max - lim.q_min)
    return model, exp.q0, lim.q_min + band, lim.q_max - band, lim.q_max - lim.q_min


def _to_end(steps: Any) -> Any:
    try:
        while True:
            next(steps)
    except StopIteration as stop:
        return stop.value


def _mc05_search() -> tuple[Any, ...]:
    law, _ = _mc05_law(1)
    exp = build(draw_sample(load_campaign("mc05-joint-limits"), 0, MC05_SAMPLE).scenario)
    lim = exp.limits
    band = 0.0102 * (lim.q_max - lim.q_min)
    return law.last_model, exp.q0, lim.q_min + band, lim.q_max - band, lim.q_max - lim.q_min


def _sequential(model: Any, q: Any, lo: Any, hi: Any, span: Any) -> tuple[Any, Any]:
    """The pose stage run to its end, then (if it met no exact goal) the feature stage."""
    bMc = model.robot.kinematics(q, check_limits=False)[0]
    target = model.camera_goal(bMc) if hasattr(model, "camera_goal") else camera_goal(model, bMc)
    met = Met()
    if target is not None:
        _to_end(_pose_stage(model, target, search_seeds(q, lo, hi, span), lo, hi, _ok, met))
    if met.pose:
        return nearest_goal(model, met.pose, q, lo, hi)
    _to_end(_feature_stage(model, search_seeds(q, lo, hi, span), lo, hi, _ok, met))
    assert met.feature is not None
    return met.feature


@pytest.mark.parametrize("start", ["panda 0", "panda 3", "mc05 7"])
def test_the_goal_met_so_far_then_the_result_of_the_stages_one_after_the_other(
    start: str,
) -> None:
    """While the search runs the law gets an exact goal as soon as one is met (the feature
    stage's on mc05, whose pose stage meets none); the search's result is the one of the
    pose stage run to its end, then the feature stage (the pose stage's nearest goal first)."""
    model, q, lo, hi, span = _panda_search(int(start[-1])) if "panda" in start else _mc05_search()
    search = GoalSearch(60)
    search.start(model, q, lo, hi, span)
    early: list[Any] = []
    done, result, calls = False, None, 0
    while not done:
        done, result = search.advance(None, steps=20)
        calls += 1
        if not done and not early and search.early() is not None:
            early.append((calls, search.early()))
    assert early and early[0][1][0] < TOL and early[0][0] <= 10
    want = _sequential(model, q, lo, hi, span)
    assert result is not None and np.array_equal(result[1], want[1]) and result[0] == want[0]


def _ok(q: Any) -> bool:
    return True


def search_seeds(q: Any, lo: Any, hi: Any, span: Any) -> list[Any]:
    """:meth:`GoalSearch.start`'s seeds (60 uniform)."""
    gen = np.random.default_rng(0)
    seeds = [q] + [q + gen.normal(0.0, 0.15, q.shape) * span for _ in range(6)]
    return seeds + [gen.uniform(lo, hi) for _ in range(60)]


def test_mc05_sample_converges_as_with_the_whole_search() -> None:
    """mc05 sample 7 converges in 48 iterations, as with the whole search in one step
    (181 with the stages one after the other, spread over periods)."""
    _, res = _mc05_law(600)
    assert res.outcome == "converged" and res.summary.iterations <= 60


def test_the_runs_do_not_depend_on_the_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without a time_budget (simulations, campaigns) a run is the same on a clock that
    advances 10 s at each reading (a machine loaded beyond any budget) as on the real one:
    the search's work per period is counted in iterations (``goal_steps``), not time."""
    _, ref = _mc05_law(30)
    readings = iter(np.arange(0.0, 1e9, 10.0))
    monkeypatch.setattr(time, "perf_counter", lambda: float(next(readings)))
    law, slow = _mc05_law(30)
    assert law.clock() > 0.0  # the law reads the slow clock
    assert np.array_equal(ref.log.qdot, slow.log.qdot) and np.array_equal(ref.log.q, slow.log.q)
