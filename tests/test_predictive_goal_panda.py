"""The predictive law's goal while its search runs (docs/predictive.md, "Joint goal"): the
feature stage's exact goal only while the pose stage has met none. The pose stage's result
is the nearest of four exact goals; steering to the first ones met (often far: 0.84 of a
joint's range on panda-near-limits sample 66), then to the next, left the Panda far from the
end's choice, and samples 66 and 149 stalled at the iteration cap (both converged before the
stages ran in turn). mc05-joint-limits, whose pose stage meets none, keeps its early goal
(tests/test_predictive_goal_early.py)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.campaign.definition import load_campaign
from redservo.campaign.sampling import draw_sample
from redservo.experiment.build import build
from redservo.redundancy.predictive_goal import TOL, GoalSearch, goal_error
from redservo.redundancy.predictive_model import point_model

PANDA_SAMPLE = 66
"""panda-near-limits (seed 0) sample 66: the feature stage meets a goal first (period 24),
the pose stage its first of four at period 28, the search ends at period 37."""


def _panda(i: int) -> Any:
    return build(draw_sample(load_campaign("panda-near-limits"), 0, i).scenario)


def test_a_pose_goal_is_not_steered_to_before_the_search_ends() -> None:
    """While the search runs, :meth:`GoalSearch.early` gives the feature stage's exact goal
    until the pose stage meets one, then nothing (the law keeps the goal it has): never one
    of the pose stage's first goals, which the nearest of four replaces at the end."""
    exp = _panda(PANDA_SAMPLE)
    bMc, J = exp.robot.kinematics(exp.q0, check_limits=False)
    model = point_model(exp.robot, exp.task, exp.task.evaluate(exp.scene, bMc, J, 0.0), exp.q0)
    lim = exp.limits
    band = 0.0102 * (lim.q_max - lim.q_min)
    search = GoalSearch(60)
    search.start(model, exp.q0, lim.q_min + band, lim.q_max - band, lim.q_max - lim.q_min)
    seen = {"feature": 0, "pose met, early": 0, "pose met": 0}
    done, result = False, None
    while not done:
        done, result = search.advance(None, steps=20)
        if done:
            break
        met, early = search._met, search.early()
        if not met.pose:
            if early is not None:
                assert met.feature is not None and np.array_equal(early[1], met.feature[1])
                seen["feature"] += 1
            continue
        seen["pose met"] += 1
        seen["pose met, early"] += early is not None
    assert seen["feature"] > 0 and seen["pose met"] > 0, seen
    assert seen["pose met, early"] == 0, seen
    assert result is not None and result[0] < TOL and goal_error(model, result[1]) < TOL


@pytest.mark.parametrize("sample", [66, 149])
def test_panda_samples_converge(sample: int) -> None:
    """panda-near-limits samples 66 and 149 converge on the ideal sensor (they ended at the
    500-iteration cap when the law steered to the pose stage's first goals)."""
    summary = _panda(sample).run(method="predictive").summary
    assert summary.outcome == "converged", (summary.outcome, summary.iterations)
    assert summary.iterations < 400
