"""Benchmark: one law call ``law(J1=..., e1=..., q=..., limits=..., lam, dt)`` (issue 18).

    .venv/bin/python benchmarks/bench_law_call.py [--rounds R] [--batch B] [--json out.json]

On the ``afma6-4points`` case of :mod:`redservo.bench.cases` (4-point IBVS on the Afma6),
with the 8 point coordinates as the task (``J1 = L J``, 8x6, no combination matrix) and
with the case's own 6x6 combination (``J1 = C L J``), the laws ``classical``, ``gpm``,
``iterative-smooth``, ``directional`` and ``sns`` are called with their defaults (shield
on, robust on) at the case's ``q``, ``λ = 0.5 1/s``, ``dt = 0.04 s``. The whole compiled
step (the campaign loop's iteration, :func:`redservo.bench.sensed.sensed_iteration`,
classical, 6x6) is timed in the same rounds
as a yardstick for the machine's load.

Each item is timed in batches of ``--batch`` calls; the rounds interleave the items, so a
change of load touches them alike; the figures are medians (µs per call) with the
inter-quartile range. Target (issue 18): the classical law call on 8x6 ≤ 15 µs.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import numpy as np
from bench_object_path import measure, timing_args

from redservo import make_law
from redservo.bench.cases import bench_cases

METHODS = ("classical", "gpm", "iterative-smooth", "directional", "sns")
TARGET_US = 15.0
"""Issue 18's target for the classical law call on the 8x6 task (µs, median)."""


def items() -> list[tuple[str, Callable[[], Any]]]:
    """The named callables, built once on the ``afma6-4points`` case."""
    from redservo.bench.sensed import sensed_iteration

    case = next(c for c in bench_cases(scaling=()) if c.name == "afma6-4points")
    robot, scene, task, q, limits = case.robot, case.scene, case.task, case.q, case.limits
    lam, dt = case.lam, case.dt
    bMc, J = robot.kinematics(q)
    st = task.evaluate(scene, bMc, J, 0.0)
    tasks = {"8x6": (np.ascontiguousarray(st.L @ J), st.e), "6x6": (st.J1, st.e1)}
    laws = {m: make_law(m) for m in METHODS}
    step = sensed_iteration(robot, scene, task, laws["classical"], limits=limits, lam=lam, dt=dt)

    def call(law: Any, J1: np.ndarray, e1: np.ndarray) -> Callable[[], Any]:
        return lambda: law(J1=J1, e1=e1, q=q, limits=limits, lam=lam, dt=dt)

    out = [(f"{m} {t}", call(laws[m], *tasks[t])) for t in ("8x6", "6x6") for m in METHODS]
    return [*out, ("compiled step classical 6x6", lambda: step(q))]


def main() -> None:
    args, load = timing_args(__doc__.split("\n\n")[0])
    res = measure(items(), args.rounds, args.batch)
    print("| law call (afma6-4points) | median µs | IQR µs |")
    print("|---|---:|---:|")
    for name, r in res.items():
        print(f"| {name} | {r['median_us']:.1f} | {r['q25_us']:.1f}–{r['q75_us']:.1f} |")
    got = res["classical 8x6"]["median_us"]
    verdict = "met" if got <= TARGET_US else "missed"
    print(f"\nclassical 8x6: {got:.1f} µs, target ≤ {TARGET_US:g} µs ({verdict})")
    if args.json is not None:
        args.json.write_text(json.dumps({"load": load, "items": res}, indent=2) + "\n")


if __name__ == "__main__":
    main()
