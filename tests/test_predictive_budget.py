"""The predictive law's time budget is enforced during the step, on an injected fake clock
(issue 32, item 2): no wall time is read."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo import Flag, make_law
from tests.test_predictive import DT, _panda_state


class FakeClock:
    """Seconds that advance only when :meth:`advance` is called."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds


def _law(clock: FakeClock, **options: Any) -> tuple[Any, dict[str, Any], list[int]]:
    """A budgeted predictive law on the Panda 4-point task, its keywords, and a list that
    counts its QP solves (each solve takes 2 ms of fake time)."""
    exp, state = _panda_state()
    law = make_law("predictive", time_budget=0.005, goal_weight=0.0, **options)
    law.clock = clock
    law.observe(exp.robot, exp.task, state)
    solves: list[int] = []
    solve = law._solve

    def timed(qp: Any, start: Any) -> Any:
        solves.append(1)
        clock.advance(0.002)
        return solve(qp, start)

    law._solve = timed
    kw = {"J1": state.J1, "e1": state.e1, "q": exp.q0, "limits": exp.limits, "lam": 0.5, "dt": DT}
    return law, kw, solves


def test_within_budget_every_sqp_iteration_runs() -> None:
    law, kw, solves = _law(FakeClock(), sqp_iterations=2)
    res = law(**kw)
    assert len(solves) == 2 and not res.diagnostics.has(Flag.SOLVER_FALLBACK)


def test_the_deadline_stops_the_sqp_iterations_and_the_fallback_is_at_hand() -> None:
    """Three 2 ms solves do not fit in 5 ms: the third is not started, the step returns the
    qp law's command (computed before the model) flagged by the time budget."""
    law, kw, solves = _law(FakeClock(), sqp_iterations=5)
    res = law(**kw)
    assert len(solves) == 3  # 0, 2, 4 ms: started before the deadline; 6 ms: not
    d = res.diagnostics
    assert d.has(Flag.SOLVER_ITERATIONS) and d.has(Flag.SOLVER_FALLBACK)
    assert any("time budget" in note for note in d.notes)
    assert np.array_equal(res.qdot, make_law("qp", margin=law.margin)(**kw).qdot)


def test_a_model_that_overruns_skips_every_solve() -> None:
    """The model's set-up takes the whole budget: no QP is built or solved."""
    clock = FakeClock()
    law, kw, solves = _law(clock)
    obs = law._obs

    def slow(q: Any, seen: Any) -> Any:
        clock.advance(0.006)
        return obs(q, seen)

    law._obs = slow
    res = law(**kw)
    assert solves == [] and res.diagnostics.has(Flag.SOLVER_FALLBACK)


@pytest.mark.parametrize("budget", [None, 0.005])
def test_the_goal_search_stops_at_half_the_budget_on_the_laws_clock(budget: Any) -> None:
    """Each search iteration takes 2 ms of fake time: without a budget a step runs
    ``goal_steps`` of them (never the whole search), with 5 ms it stops past 2.5 ms."""
    exp, state = _panda_state()
    clock = FakeClock()
    law = make_law("predictive", time_budget=budget, goal_steps=5)
    law.clock = clock
    law.observe(exp.robot, exp.task, state)
    steps = law._search
    start = steps.start
    seeds: list[int] = []

    def counted(*args: Any) -> None:
        start(*args)
        inner = steps._steps

        def ticking() -> Any:
            while True:
                try:
                    next(inner)
                except StopIteration as stop:
                    return stop.value
                seeds.append(1)
                clock.advance(0.002)
                yield

        steps._steps = ticking()

    steps.start = counted
    law(J1=state.J1, e1=state.e1, q=exp.q0, limits=exp.limits, lam=0.5, dt=DT)
    if budget is None:
        assert len(seeds) == 5 and steps.running  # goal_steps, the rest in the next periods
    else:
        assert len(seeds) == 2 and steps.running  # 2, 4 ms > 2.5 ms: goes on next period
