"""Benchmark: the public object path of one control step, 4-point Afma6 (issue 18).

    .venv/bin/python benchmarks/bench_object_path.py [--rounds R] [--batch B] [--json out.json]

What the README shows for a real robot, on the ``afma6-4points`` case of
:mod:`redservo.bench.cases` (a 0.2 m square at 0.6 m, the start rotated 80° about the
optical axis; m = 6, n = 6):

* ``kinematics``: ``robot.kinematics(q)`` (``bMc`` and ``J``);
* ``task.evaluate``: ``task.evaluate(scene, bMc, J, 0.0)`` (``s``, ``e1``, ``J1``);
* ``evaluate_measured``: ``task.evaluate_measured(s, inv_depth, J)`` (a sensor's entry);
* ``law classical`` / ``law iterative-smooth``: ``law(J1=..., e1=..., q=..., limits=...,
  lam=0.5, dt=0.04)``;
* ``path classical`` / ``path iterative-smooth``: the three calls in a row (the sum);
* ``compiled measured``: the step a user's arm runs: the compiled kernel of the
  Controller (:func:`redservo.kernels.control.robot_control`: kinematics, ``L(s, 1/Z)``,
  CM01 eq. 25, the law, its safety layer and events) on measured features, called
  directly with its packs, no Python around it: the ratios ``path / compiled`` and
  ``Controller.step / compiled`` use it;
* ``Controller.step`` / ``Controller.step python``: :meth:`redservo.Controller.step` on the
  measured features, on its compiled engine and on the object path (``engine="python"``);
  target (issue 29): the compiled engine ≤ 1.3x the compiled kernel.

Each item is timed in batches of ``--batch`` calls; the rounds interleave the items, so a
change of machine load touches all of them alike; the figures are medians (µs per call)
with the inter-quartile range. The first line gives the load average: on a shared
machine, run it more than once, or time with ``--clock cpu`` (the CPU time of the timing
thread, which a busy machine inflates far less than the wall clock). Targets (issue 18): ``task.evaluate`` ≤ 10 µs, the
classical law call ≤ 15 µs, the path ≤ 30 µs.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from redservo import make_law
from redservo.bench.cases import bench_cases

TARGETS_US = {"task.evaluate": 10.0, "law classical": 15.0, "path classical": 30.0}
"""Issue 18's targets (µs, medians) for the items that have one."""
VISP_US = 7.3
"""ViSP 3.5's ``vpServo`` step on the same 4-point Afma6 case (µs), as issue 29 measured it
side by side on this machine (a hidden harness: ViSP is not a dependency)."""
VISP_TARGETS = {"path classical": 2.5, "path iterative-smooth": 2.5, "compiled measured": 1.3}
"""Issue 29's targets as ratios to :data:`VISP_US`."""


def items() -> list[tuple[str, Callable[[], Any]]]:
    """The named callables, built once on the ``afma6-4points`` case."""
    case = next(c for c in bench_cases(scaling=()) if c.name == "afma6-4points")
    robot, scene, task, q, limits = case.robot, case.scene, case.task, case.q, case.limits
    lam, dt = case.lam, case.dt
    bMc, J = robot.kinematics(q)
    st = task.evaluate(scene, bMc, J, 0.0)
    J1, e1 = st.J1, st.e1
    s, inv_depth = st.s, st.inv_depth
    laws = {m: make_law(m) for m in ("classical", "iterative-smooth")}
    from redservo import Controller
    from redservo.control import Measurement

    meas = Measurement(s, tuple(inv_depth))
    ctl = {
        e: Controller(robot, task, make_law("classical"), limits, lam=lam, dt=dt, engine=e)
        for e in ("auto", "python")
    }

    def law_call(law: Any) -> Callable[[], Any]:
        return lambda: law(J1=J1, e1=e1, q=q, limits=limits, lam=lam, dt=dt)

    def path(law: Any) -> Callable[[], Any]:
        def run() -> Any:
            bMc, J = robot.kinematics(q)
            st = task.evaluate(scene, bMc, J, 0.0)
            return law(J1=st.J1, e1=st.e1, q=q, limits=limits, lam=lam, dt=dt)

        return run

    return [
        ("kinematics", lambda: robot.kinematics(q)),
        ("task.evaluate", lambda: task.evaluate(scene, bMc, J, 0.0)),
        ("evaluate_measured", lambda: task.evaluate_measured(s, inv_depth, J)),
        ("law classical", law_call(laws["classical"])),
        ("law iterative-smooth", law_call(laws["iterative-smooth"])),
        ("path classical", path(laws["classical"])),
        ("path iterative-smooth", path(laws["iterative-smooth"])),
        ("compiled measured", _measured_kernel(ctl["auto"], q, meas)),
        ("Controller.step", lambda: ctl["auto"].step(q, meas, 0.0, qdot_prev=None)),
        ("Controller.step python", lambda: ctl["python"].step(q, meas, 0.0, qdot_prev=None)),
    ]


def _measured_kernel(ctl: Any, q: Any, meas: Any) -> Callable[[], Any]:
    """The compiled kernel of ``ctl``'s step on ``meas`` with its packs made once (what
    :meth:`redservo.binding.control.CompiledControl.step` calls, without its Python)."""
    eng = ctl._compiled
    iz = eng._inverse_depths(meas.inv_depth)
    packs = ((meas.s, iz, eng.s_star, eng.C), eng.law_pack, eng.limits_pack, eng.gains)
    none = np.zeros(0)

    def run() -> Any:
        return eng.kernel(q, eng.robot, *packs, (none, none, none), np.empty(eng.size))

    return run


def measure(
    named: list[tuple[str, Callable[[], Any]]], rounds: int, batch: int, cpu: bool = False
) -> dict[str, dict[str, float]]:
    """Median and quartiles (µs per call) of every ``(name, fn)`` over interleaved rounds,
    wall-clock or (``cpu``) CPU time of this thread."""
    for _, fn in named:  # warm-up: compile or load every kernel first
        for _ in range(50):
            fn()
    clock = time.thread_time_ns if cpu else time.perf_counter_ns
    times = np.empty((rounds, len(named)))
    for r in range(rounds):
        for i, (_, fn) in enumerate(named):
            t0 = clock()
            for _ in range(batch):
                fn()
            times[r, i] = (clock() - t0) / batch / 1e3
    out = {}
    for i, (name, _) in enumerate(named):
        q25, med, q75 = np.percentile(times[:, i], [25, 50, 75])
        out[name] = {"median_us": float(med), "q25_us": float(q25), "q75_us": float(q75)}
    return out


def timing_args(description: str) -> tuple[argparse.Namespace, tuple[float, float, float]]:
    """The options of a timing benchmark (--rounds, --batch, --json) and the load average,
    said on stderr before the timing starts."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--rounds", type=int, default=15, help="interleaved rounds (default 15)")
    parser.add_argument("--batch", type=int, default=2000, help="calls per timing (default 2000)")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")
    parser.add_argument(
        "--clock",
        choices=("wall", "cpu"),
        default="wall",
        help="time with the wall clock (default) or the CPU time of the timing thread",
    )
    args = parser.parse_args()
    load = os.getloadavg()
    print(
        f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; warming up and timing "
        f"{args.rounds} rounds x {args.batch} calls per item...",
        file=sys.stderr,
    )
    return args, load


def visp_lines(res: dict[str, dict[str, float]], visp_us: float = VISP_US) -> list[str]:
    """The items with an issue-29 target as ratios to ViSP's step (``visp_us``, µs)."""
    out = []
    for name, target in VISP_TARGETS.items():
        ratio = res[name]["median_us"] / visp_us
        mark = "met" if ratio <= target else "missed"
        out.append(f"{name} / ViSP ({visp_us:g} µs): {ratio:.2f}x (target ≤ {target:g}x: {mark})")
    return out


def main() -> None:
    args, load = timing_args(__doc__.split("\n\n")[0])
    res = measure(items(), args.rounds, args.batch, args.clock == "cpu")
    compiled = res["compiled measured"]["median_us"]
    print("| item (afma6-4points) | median µs | IQR µs | target |")
    print("|---|---:|---:|---|")
    for name, r in res.items():
        target = TARGETS_US.get(name)
        mark = (
            ""
            if target is None
            else f"≤ {target:g} ({'met' if r['median_us'] <= target else 'missed'})"
        )
        print(f"| {name} | {r['median_us']:.1f} | {r['q25_us']:.1f}–{r['q75_us']:.1f} | {mark} |")
    for m in ("classical", "iterative-smooth"):
        ratio = res[f"path {m}"]["median_us"] / compiled
        print(f"\npath {m} / compiled measured step: {ratio:.1f}x")
    ratio = res["Controller.step"]["median_us"] / compiled
    mark = "met" if ratio <= 1.3 else "missed"
    print(f"\nController.step / compiled measured step: {ratio:.2f}x (target ≤ 1.3x: {mark})")
    print()
    for line in visp_lines(res):
        print(line)
    if args.json is not None:
        data = {
            "case": "afma6-4points",
            "load_avg": list(load),
            "rounds": args.rounds,
            "batch": args.batch,
            "clock": args.clock,
            "items": res,
        }
        args.json.write_text(json.dumps(data, indent=2))
        print(f"wrote {args.json}", file=sys.stderr)


if __name__ == "__main__":
    main()
