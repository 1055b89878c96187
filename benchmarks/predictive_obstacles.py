"""Benchmark: ``predictive`` among obstacles against the same campaign without them.

    .venv/bin/python benchmarks/predictive_obstacles.py [--campaign panda-posts] \
        [--samples 6] [--rounds 2]

``predictive`` runs on the object path (its step is Python); with collision avoidance on,
its step also measures the pairs along its plan (the distance rows over the horizon,
:mod:`redservo.redundancy.predictive_distance`) and keeps its joint goal clear of the
obstacles. Per round, alternated in this process (``workers=1``, a 1-sample warm-up each):
``--samples`` samples of the campaign with ``--methods predictive``, with its obstacles and
without (``obstacles = []``, ``collision.enabled = false``), in steps per CPU second
(``time.process_time``), and where a step's CPU goes: the law's ``compute``, the joint-goal
search in it (:meth:`~redservo.redundancy.predictive.Predictive._update_goal`; the share of
steps on which the search runs), and the horizon's distance rows
(:func:`~redservo.redundancy.predictive_qp.with_horizon_rows`). docs/scaling.md gives the
numbers.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

__all__ = ["main", "split"]


def _timed(owner: Any, name: str, acc: dict[str, float]) -> Callable[[], None]:
    """Accumulate the CPU seconds of ``owner.name`` in ``acc[name]``; returns the undo."""
    fn = getattr(owner, name)

    def timed(*args: Any, **kwargs: Any) -> Any:
        t = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            acc[name] = acc.get(name, 0.0) + time.process_time() - t

    setattr(owner, name, timed)
    return lambda: setattr(owner, name, fn)


def split(defn: Any, samples: int) -> str:
    """One line: steps per CPU s of ``samples`` samples of ``defn`` (``predictive`` alone,
    after a 1-sample warm-up) and the CPU ms per step of the parts (module docstring)."""
    from redservo.campaign import run_campaign
    from redservo.redundancy import predictive_qp
    from redservo.redundancy.predictive import Predictive
    from redservo.redundancy.predictive_goal import GoalSearch

    methods = ["predictive"]
    run_campaign(defn, samples=1, methods=methods, workers=1, progress=False)
    acc: dict[str, float] = {}
    undo = [
        _timed(Predictive, "compute", acc),
        _timed(Predictive, "_update_goal", acc),
        _timed(predictive_qp, "with_horizon_rows", acc),
    ]
    calls = {"advance": 0}
    advance = GoalSearch.advance

    def counted(self: Any, *args: Any, **kwargs: Any) -> Any:
        calls["advance"] += 1
        return advance(self, *args, **kwargs)

    GoalSearch.advance = counted  # type: ignore[method-assign]
    try:
        cpu = time.process_time()
        res = run_campaign(defn, samples=samples, methods=methods, workers=1, progress=False)
        cpu = time.process_time() - cpu
    finally:
        GoalSearch.advance = advance  # type: ignore[method-assign]
        for u in reversed(undo):
            u()
    steps = sum(int(r["iterations"]) for r in res.rows)
    ms = {k: 1e3 * v / steps for k, v in acc.items()}
    return (
        f"{steps} steps, {cpu:.2f} CPU s: {steps / cpu:,.0f} steps per CPU s; CPU ms a step: "
        f"all {1e3 * cpu / steps:.2f}, law {ms['compute']:.2f}, goal search "
        f"{ms['_update_goal']:.2f} (running on {100 * calls['advance'] / steps:.0f} % of "
        f"the steps), horizon rows {ms['with_horizon_rows']:.2f}"
    )


def main(argv: Sequence[str] | None = None) -> int:
    from redservo.campaign import load_campaign
    from redservo.scenario import apply_overrides

    p = argparse.ArgumentParser(
        prog="python benchmarks/predictive_obstacles.py", description=__doc__
    )
    p.add_argument("--campaign", default="panda-posts")
    p.add_argument("--samples", type=int, default=6)
    p.add_argument("--rounds", type=int, default=2)
    a = p.parse_args(argv)
    defn = load_campaign(a.campaign)
    off = ["obstacles=[]", "collision.enabled=false"]
    free = replace(defn, scenario=apply_overrides(defn.scenario, off))
    for r in range(a.rounds):
        print(f"round {r + 1}: load average {os.getloadavg()[0]:.1f}")
        print(f"  with obstacles: {split(defn, a.samples)}", flush=True)
        print(f"  without:        {split(free, a.samples)}", flush=True)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
