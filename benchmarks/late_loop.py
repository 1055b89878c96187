"""A late servo loop near the joint limits: hard-limit contacts over randomized runs (issue 32).

    .venv/bin/python benchmarks/late_loop.py [--runs 100] [--seed 0] [--max-periods 5]

Each run puts a simulated Afma6 (on a :class:`~redservo.hardware.VirtualClock`, so the run
is deterministic and takes no wall-clock time) at a random configuration whose joints lie
within 0.05 rad or m of a safe limit (limits less a 0.02 margin), with a random actuator
(ideal, or first-order lag τ up to 0.05 s with up to one period of delay), and runs a
:class:`~redservo.hardware.ServoLoop` (T = 40 ms, watchdog 0.3 s) with a hostile law: it
commands ``q̇max`` on every joint toward the nearer limit and takes a random time, uniform
in ``[0, max_periods · T]``, per call. A *contact* is a run where the simulated robot
reached a hard limit (its protective stop).

Two configurations are reported:

* ``hold``: the guard planning over ``max_hold`` = the watchdog (0.3 s, more than the
  longest time between two sends, 6 T), no overrun bound: what the hold-bound guard alone
  guarantees, over all 150 iterations of every run;
* ``default``: ``Supervision()``, the loop's defaults (a run may end ``late`` after 5
  consecutive overruns).

``min_distance`` is the least distance (m or rad) of a logged joint reading to a hard limit
over all runs (the margin is 0.02). The exit code is 1 if a configuration had a contact.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from typing import Any

import numpy as np

from redservo import make_law
from redservo.features import PointFeature
from redservo.hardware import (
    ActuatorModel,
    IdealFeatureSource,
    ServoLoop,
    SimulatedRobot,
    Supervision,
    VirtualClock,
)
from redservo.robots import Afma6
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

T = 0.04
WATCHDOG = 0.3
MARGIN = 0.02
CONFIGS: dict[str, Supervision] = {
    "hold": Supervision(max_overruns=10**9),
    "default": Supervision(),
}


def _hostile_law(clock: VirtualClock, rng: np.random.Generator, max_periods: float) -> Any:
    """Full speed toward the nearer limit, taking up to ``max_periods`` periods per call."""
    inner = make_law("classical")

    def law(**kw: Any) -> Any:
        lim, q = kw["limits"], np.asarray(kw["q"], dtype=float)
        toward = np.where(lim.q_max - q < q - lim.q_min, 1.0, -1.0)
        clock.advance(float(rng.uniform(0.0, max_periods * T)))
        return inner(**kw)._replace(qdot=toward * lim.qdot_max)

    return law


def late_run(
    seed: int, sup: Supervision, *, max_periods: float = 5.0, iterations: int = 150
) -> Any:
    """One randomized run; return ``(contact, outcome, deepest)``: whether the robot reached a
    hard limit, the loop's outcome, and the least distance (m or rad) to a hard limit."""
    rng = np.random.default_rng(seed)
    robot = Afma6()
    limits = robot.limits().replace(margin_abs=MARGIN)
    near_max = rng.random(robot.n) < 0.5
    depth = rng.uniform(0.0, 0.05, robot.n)
    q0 = np.where(near_max, limits.safe_max - depth, limits.safe_min + depth)
    if rng.random() < 0.5:
        act = ActuatorModel.ideal()
    else:
        act = ActuatorModel(tau=float(rng.uniform(0.0, 0.05)), delay_steps=int(rng.integers(0, 2)))
    clock = VirtualClock(10.0)
    sim = SimulatedRobot(robot, act, q0, clock, period=T)
    wMo = robot.fkine(q0) @ make_transform(t=(0.05, -0.03, 0.6))
    scene = Scene([PointSet("target", np.zeros((1, 3)), trajectory=Static(wMo))])
    task = VisualTask([TaskTerm(PointFeature(), "target")], [0.0, 0.0])
    src = IdealFeatureSource(task, scene, sim)
    law = _hostile_law(clock, rng, max_periods)
    loop = ServoLoop(
        sim,
        src,
        robot,
        task,
        law,
        limits,
        period=T,
        lam=1.0,
        watchdog_timeout=WATCHDOG,
        max_iterations=iterations,
        stop_at_convergence=False,
        clock=clock,
        sleep=clock.sleep,
        supervision=sup,
    )
    res = loop.run(raise_errors=False)
    log_q = res.log.q if len(res.log) else q0[None, :]
    deepest = float(np.min(np.minimum(log_q - limits.q_min, limits.q_max - log_q)))
    return sim.fault is not None, res.outcome, deepest


def main(argv: list[str] | None = None) -> int:
    """Run the campaign and print one JSON line per configuration."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-periods", type=float, default=5.0)
    args = ap.parse_args(argv)
    bad = 0
    for name, sup in CONFIGS.items():
        runs = [
            late_run(args.seed + i, sup, max_periods=args.max_periods) for i in range(args.runs)
        ]
        contacts = sum(r[0] for r in runs)
        outcomes = Counter(r[1] for r in runs)
        row = {"config": name, "runs": args.runs, "contacts": contacts}
        row |= {"outcomes": dict(outcomes), "min_distance": min(r[2] for r in runs)}
        print(json.dumps(row))
        bad += contacts
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
