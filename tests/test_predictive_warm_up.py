"""The servo loop pays the predictive law's first-call costs before its first period
(``Predictive.warm_up``): a first step took about 0.2 s against a 5 ms ``time_budget``."""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo import make_law
from redservo.robots import Afma6


def test_warm_up_runs_one_unbudgeted_step_and_forgets_it() -> None:
    law: Any = make_law("predictive", time_budget=0.005)
    ticks = iter(np.arange(0.0, 10.0, 1.0))  # a clock that jumps 1 s a reading
    law.clock = lambda: float(next(ticks))
    limits = Afma6().limits()
    calls: list[dict[str, Any]] = []
    compute = law.compute
    law.compute = lambda x: calls.append({"n": x.q.shape[0], "m": x.e1.shape[0]}) or compute(x)
    law.warm_up(limits, 8, 0.04)
    assert calls == [{"n": 6, "m": 8}]
    assert next(ticks) == 0.0  # the law's clock was not read: no deadline while warming up
    assert law._U is None and law._calls == 0  # reset afterwards


def test_the_servo_loop_warms_the_law_up_before_its_first_period() -> None:
    from tests.test_servo_loop import T, _loop, _setup

    order: list[str] = []
    inner = make_law("classical")

    class Law:
        name = "mine"

        def __call__(self, **kw: Any) -> Any:
            order.append("step")
            return inner(**kw)

        def warm_up(self, limits: Any, m: int, dt: float) -> None:
            order.append(f"warm_up m={m} dt={dt}")

    clock, robot, sim, src, task = _setup()
    res = _loop(sim, src, robot, task, clock, law=Law(), max_iterations=3).run()
    assert res.iterations == 3
    assert order[0] == f"warm_up m=2 dt={T}" and order[1:] == ["step"] * 3
