"""Distance rows over the predictive law's horizon (redservo.redundancy.predictive_distance):
the rows are the distance kernel linearised at each predicted period, rest always meets them,
measuring the plan leaves the step's own measurement alone, and the law's plans keep off the
obstacle over the whole horizon (with the first-command rows alone they ran through it)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo.collision import Obstacle, Shape
from redservo.control.avoidance import Collision, check_collision
from redservo.experiment.build import build
from redservo.redundancy import make_law
from redservo.redundancy.predictive import Predictive
from redservo.redundancy.predictive_distance import horizon_distance_rows
from redservo.redundancy.predictive_model import horizon
from redservo.scenario import load_scenario
from redservo.scene import Static
from redservo.spatial import make_transform

_ROWS_ONLY = {"repel": False, "shield": False}
_BALL = (0.02, 0.06, 0.74)  # m, base frame: panda-post's ball


def _post(radius: float = 0.1, **overrides: Any) -> tuple[Any, Collision]:
    """panda-post with a bigger ball (its predictive path passes through it)."""
    exp = build(load_scenario("panda-post"))
    coll = exp.options.collision
    assert coll is not None
    ball = Obstacle("ball", Shape("sphere", radius=radius), Static(make_transform(t=_BALL)))
    return exp, dataclasses.replace(coll, obstacles=(ball,), **overrides)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_rows_are_the_distance_linearised_per_predicted_period(seed: int) -> None:
    exp, coll = _post()
    law = make_law("predictive")
    check_collision(coll, exp.robot, law)
    rng = np.random.default_rng(seed)
    n, dt = exp.q0.shape[0], 0.04
    hz = horizon(10, 3)
    q0 = exp.q0 + rng.normal(0.0, 0.05, n)
    Ubar = rng.normal(0.0, 0.4, (hz.Nc, n))
    coll.measure(exp.robot, q0, 0.0)  # the step's own measurement
    before = coll.last_time, coll.measure(exp.robot, q0, 0.0)
    rows = horizon_distance_rows(law, q0, Ubar, hz, dt)
    # The plan's measurement leaves the step's in the cache (the shield, the records use it).
    assert coll.last_time == before[0] and coll.measure(exp.robot, q0, 0.0) is before[1]
    if rows is None:
        return
    assert np.all(rows.b <= 0.0)  # rest (U = 0) meets every row
    dU = rng.normal(0.0, 1e-4, Ubar.shape)
    for r, (k, name) in enumerate(zip(rows.steps, rows.names, strict=True)):
        w = dt * hz.M[k - 1]
        at = coll.probe(exp.robot, q0 + w @ Ubar, 0.0)
        moved = coll.probe(exp.robot, q0 + w @ (Ubar + dU), 0.0)
        j = at.names.index(name)
        assert at.d[j] < coll.d_influence
        # first order: d(q̄_k + δq) − d(q̄_k) = A δU (+ O(δ²))
        assert moved.d[j] - at.d[j] == pytest.approx(rows.A[r] @ dU.reshape(-1), abs=1e-7)


def test_no_rows_when_not_avoiding_or_far() -> None:
    exp, coll = _post(radius=0.01)
    law = make_law("predictive")
    check_collision(None, exp.robot, law)
    U = np.zeros((3, exp.q0.shape[0]))
    assert horizon_distance_rows(law, exp.q0, U, horizon(10, 3), 0.04) is None
    far = dataclasses.replace(
        coll,
        obstacles=(
            Obstacle("ball", Shape("sphere", radius=0.01), Static(make_transform(t=(2, 2, 2)))),
        ),
    )
    check_collision(far, exp.robot, law)
    assert horizon_distance_rows(law, exp.q0, U, horizon(10, 3), 0.04) is None


def _plans(exp: Any, coll: Collision, monkeypatch: pytest.MonkeyPatch) -> tuple[Any, list]:
    """A closed-loop predictive run, with every step's ``(q, plan, horizon, dt)``."""
    plans: list[tuple[np.ndarray, np.ndarray, Any, float]] = []
    compute = Predictive.compute

    def spy(self: Predictive, x: Any) -> Any:
        res = compute(self, x)
        if self.last_plan is not None:
            plans.append((x.q.copy(), self.last_plan.copy(), self._hz, x.dt))
        return res

    monkeypatch.setattr(Predictive, "compute", spy)
    return exp.run(method="predictive", collision=coll), plans


@pytest.mark.parametrize("seed", [0, 4, 6, 7])
def test_no_plan_passes_through_the_obstacle(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Rows alone (no repulsion, no shield), fuzzed starts round panda-post's (some already
    inside d_safe): the run keeps its distance and every plan keeps off the ball at every
    predicted period, on the true geometry. With the first-command rows alone, the first
    plan of each of these runs went 10-28 mm into the ball."""
    exp, coll = _post(**_ROWS_ONLY)
    if seed:
        exp.q0 = exp.q0 + np.random.default_rng(seed).normal(0.0, 0.03, exp.q0.shape[0])
    res, plans = _plans(exp, coll, monkeypatch)
    d = res.log.min_distance
    assert res.outcome == "converged"
    assert d is not None and float(np.min(d)) >= min(float(d[0]), coll.d_safe) - 1e-4
    assert plans
    worst = np.inf
    for q, U, hz, dt in plans:
        for k in range(1, hz.N + 1):
            qk = q + dt * hz.M[k - 1] @ U
            worst = min(worst, float(np.min(coll.probe(exp.robot, qk, 0.0).d)))
    # Linearised at the previous plan (at rest, the first time): the plan may dip a few
    # mm under d_safe where the distance curves, never into the ball.
    assert worst > 0.0, worst


@pytest.mark.parametrize("sample", [42, 80, 77])
def test_the_joint_goal_is_clear_of_the_obstacles(
    sample: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """panda-posts samples (seed 0) whose nearest exact goal has the wrist in a ball (42,
    80: the arm was held at d_safe until the cap) or lies behind one (77: the target was
    lost on the way round): the search passes such goals over and the law converges."""
    from redservo.campaign.definition import load_campaign
    from redservo.campaign.sampling import draw_built

    _, exp = draw_built(load_campaign("panda-posts"), 0, sample)
    coll = exp.options.collision
    goals: list[np.ndarray] = []
    compute = Predictive.compute

    def spy(self: Predictive, x: Any) -> Any:
        res = compute(self, x)
        if self._goal is not None:
            goals.append(self._goal.copy())
        return res

    monkeypatch.setattr(Predictive, "compute", spy)
    res = exp.run(method="predictive")
    assert res.outcome == "converged"
    assert goals
    for g in goals:
        assert float(np.min(coll.probe(exp.robot, g, 0.0).d)) >= coll.d_safe


def test_goal_search_skips_what_is_not_clear(monkeypatch: pytest.MonkeyPatch) -> None:
    """The search's ``clear``: nothing clear, no goal; the free search's goal ruled out,
    another one (or none)."""
    from redservo.redundancy.predictive_goal import search_steps

    exp = build(load_scenario("panda-4points"))
    models: list[Any] = []
    compute = Predictive.compute

    def spy(self: Predictive, x: Any) -> Any:
        res = compute(self, x)
        models.append(self.last_model)
        return res

    monkeypatch.setattr(Predictive, "compute", spy)
    exp.run(method="predictive", max_iterations=2)
    model = next(m for m in models if m is not None)
    lo, hi = exp.limits.q_min + 0.02, exp.limits.q_max - 0.02
    seeds = [exp.q0 + 0.1 * k for k in range(3)]

    def run(clear: Any) -> Any:
        steps = search_steps(model, exp.q0, seeds, lo, hi, clear)
        try:
            while True:
                next(steps)
        except StopIteration as stop:
            return stop.value

    free = run(None)
    assert free is not None
    assert run(lambda q: False) is None
    other = run(lambda q: bool(np.max(np.abs(q - free[1])) > 1e-6))
    assert other is None or np.max(np.abs(other[1] - free[1])) > 1e-6


def test_the_obstacle_campaign_compares_the_predictive_law() -> None:
    from redservo.campaign.definition import load_campaign

    assert "predictive" in load_campaign("panda-posts").methods
