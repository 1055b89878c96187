"""Benchmark: the public object path of one control step, 4-point Afma6 (issue 18).

    .venv/bin/python benchmarks/bench_object_path.py [--rounds R] [--batch B] [--json out.json]
        [--clock wall|cpu] [--visp benchmarks/visp/visp_step] [--laws classical,gpm,...]

What the README shows for a real robot, on the ``afma6-4points`` case of
:mod:`redservo.bench.cases` (a 0.2 m square at 0.6 m, the start rotated 80° about the
optical axis; m = 6, n = 6):

* ``kinematics``: ``robot.kinematics(q)`` (``bMc`` and ``J``);
* ``task.evaluate``: ``task.evaluate(scene, bMc, J, 0.0)`` (``s``, ``e1``, ``J1``);
* ``evaluate_measured``: ``task.evaluate_measured(s, inv_depth, J)`` (a sensor's entry);
* ``law classical`` / ``law iterative-smooth``: ``law(J1=..., e1=..., q=..., limits=...,
  lam=0.5, dt=0.04)``;
* ``path classical`` / ``path iterative-smooth``: the three calls in a row (the sum);
  ``--laws`` names the laws of these two items (default :data:`LAWS`; e.g.
  ``--laws classical,gpm,iterative,iterative-smooth,wln,large-projection``);
* ``compiled measured``: the step a user's arm runs: the compiled kernel of the
  Controller (:func:`redservo.kernels.control.robot_control`: kinematics, ``L(s, 1/Z)``,
  CM01 eq. 25, the law, its safety layer and events) on measured features, called
  directly with its packs, no Python around it: the ratios ``path / compiled`` and
  ``Controller.step / compiled`` use it;
* ``Controller.step`` / ``Controller.step python``: :meth:`redservo.Controller.step` on the
  measured features at ``t = 0, dt, 2 dt, ...``, on its compiled engine and on the object
  path (``engine="python"``); ``Controller.step .qdot``: the compiled engine's step and
  its command read (the step makes its results when first read);
  target (issue 29): the compiled engine ≤ 1.3x the compiled kernel.

* ``compiled measured qp`` and ``Controller.step qp`` (``.qdot``, ``python``): the same
  with ``qp``, whose Controller step is compiled since branch ``imgspeed5``
  (:mod:`redservo.kernels.qp_control`; before, ``Controller.step qp`` was its object path
  and the kernel item is absent);
* ``compiled qp``: the campaign loop's iteration with ``qp``
  (:func:`redservo.bench.sensed.sensed_iteration`: kinematics, ideal sensor and CM01 eq. 25,
  then the law's kernels and its compiled box-QP solver);
* ``visp step`` (with ``--visp PATH``): ViSP 3.5's ``vpServo`` step on the same case, timed
  in batches by the optional harness ``benchmarks/visp/visp_step`` (build it with
  ``sh benchmarks/visp/build.sh``; ViSP is GPL: a separate program, never needed by
  redservo), in the same rounds as the other items; the ratios to ViSP then use the ViSP
  time of this run, and the agreement of ViSP's numbers with redservo's on the same inputs
  is printed too. Without ``--visp`` the ratios use :data:`VISP_US`.

Each item is timed in batches of ``--batch`` calls; the rounds interleave the items, so a
change of machine load touches all of them alike; the figures are medians (µs per call)
with the inter-quartile range. The first line gives the load average: on a shared
machine, run it more than once, or time with ``--clock cpu`` (the CPU time of the timing
thread, which a busy machine inflates far less than the wall clock). Targets (issue 18): ``task.evaluate`` ≤ 10 µs, the
classical law call ≤ 15 µs, the path ≤ 30 µs.
"""

from __future__ import annotations

import argparse
import itertools
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
from redservo.errors import RedservoError

LAWS = ("classical", "iterative-smooth")
"""The laws of the ``law ...`` and ``path ...`` items unless ``--laws`` says otherwise."""
TARGETS_US = {"task.evaluate": 10.0, "law classical": 15.0, "path classical": 30.0}
"""Issue 18's targets (µs, medians) for the items that have one."""
VISP_US = 7.3
"""ViSP 3.5's ``vpServo`` step on the same 4-point Afma6 case (µs), as issue 29 measured it
on a quiet machine: the fallback when the harness (``--visp``) is not given."""
VISP_TARGETS = {
    "path classical": 2.5,
    "path iterative-smooth": 2.5,
    "compiled measured": 1.3,
    "compiled qp": 1.6,
}
"""Issue 29's targets as ratios to ViSP's step."""
VISP_ITEM = "visp step"
"""The name of ViSP's step among the timed items (``--visp``)."""


def the_case() -> Any:
    """The ``afma6-4points`` bench case."""
    return next(c for c in bench_cases(scaling=()) if c.name == "afma6-4points")


def items(case: Any = None, laws: tuple[str, ...] = LAWS) -> list[tuple[str, Callable[[], Any]]]:
    """The named callables, built once on the ``afma6-4points`` case; ``laws``: those of the
    ``law ...`` and ``path ...`` items."""
    from redservo.bench.sensed import sensed_iteration

    case = the_case() if case is None else case
    robot, scene, task, q, limits = case.robot, case.scene, case.task, case.q, case.limits
    lam, dt = case.lam, case.dt
    bMc, J = robot.kinematics(q)
    st = task.evaluate(scene, bMc, J, 0.0)
    J1, e1 = st.J1, st.e1
    s, inv_depth = st.s, st.inv_depth
    made = {m: make_law(m) for m in laws}
    qp_step = sensed_iteration(robot, scene, task, make_law("qp"), limits=limits, lam=lam, dt=dt)
    from redservo import Controller
    from redservo.control import Measurement

    meas = Measurement(s, tuple(inv_depth))
    ctl = {
        e: Controller(robot, task, make_law("classical"), limits, lam=lam, dt=dt, engine=e)
        for e in ("auto", "python")
    }
    qp = {
        e: Controller(robot, task, make_law("qp"), limits, lam=lam, dt=dt, engine=e)
        for e in ("auto", "python")
    }
    qp_kernel = [] if qp["auto"]._compiled is None else [_measured_kernel(qp["auto"], q, meas)]

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
        *((f"law {m}", law_call(made[m])) for m in laws),
        *((f"path {m}", path(made[m])) for m in laws),
        ("compiled measured", _measured_kernel(ctl["auto"], q, meas)),
        ("compiled qp", lambda: qp_step(q)),
        ("Controller.step", _stepping(ctl["auto"], q, meas, dt)),
        ("Controller.step .qdot", _stepping(ctl["auto"], q, meas, dt, read=True)),
        ("Controller.step python", _stepping(ctl["python"], q, meas, dt)),
        *(("compiled measured qp", k) for k in qp_kernel),
        ("Controller.step qp", _stepping(qp["auto"], q, meas, dt)),
        ("Controller.step qp .qdot", _stepping(qp["auto"], q, meas, dt, read=True)),
        ("Controller.step qp python", _stepping(qp["python"], q, meas, dt)),
    ]


def _stepping(ctl: Any, q: Any, meas: Any, dt: float, read: bool = False) -> Callable[[], Any]:
    """``ctl.step`` on ``meas`` at ``t = 0, dt, 2 dt, ...`` (s), as a loop calls it: the
    controller's command history then keeps its last second of commands, as in a run (at a
    fixed ``t`` it would grow by one entry per call, and the garbage collector's work with it).
    ``read``: and read the step's command (``step.qdot``, what a loop sends; the compiled
    engine makes it when first read)."""
    clock = itertools.count()

    def run() -> Any:
        return ctl.step(q, meas, dt * next(clock), qdot_prev=None)

    def run_read() -> Any:
        return ctl.step(q, meas, dt * next(clock), qdot_prev=None).qdot

    return run_read if read else run


def _measured_kernel(ctl: Any, q: Any, meas: Any) -> Callable[[], Any]:
    """The compiled kernel of ``ctl``'s step on ``meas`` with its packs made once (what
    :meth:`redservo.binding.control.CompiledControl.step` calls, without its Python): at its
    entry point (:mod:`redservo.kernels.entry`) once the Controller's steps found it."""
    eng = ctl._compiled
    iz = eng._inverse_depths(meas.inv_depth)
    packs = ((meas.s, iz, eng.s_star, eng.C), eng.law_pack, eng.limits_pack, eng.gains)
    none = np.zeros(0)

    def run() -> Any:  # the entry point once the Controller's steps found it, as they call it
        entry, args = (
            getattr(eng, "entry", [None])[0],
            (*packs, (none, none, none), np.empty(eng.size)),
        )
        return eng.kernel(q, eng.robot, *args) if entry is None else entry(q, eng.robot, args)

    return run


def measure(
    named: list[tuple[str, Any]], rounds: int, batch: int, cpu: bool = False
) -> dict[str, dict[str, float]]:
    """Median and quartiles (µs per call) of every ``(name, fn)`` over interleaved rounds,
    wall-clock or (``cpu``) CPU time of this thread. An ``fn`` with a ``per_call_us(batch,
    cpu)`` method (ViSP's harness) times its own batch, in its turn of every round."""
    for _, fn in named:  # warm-up: compile or load every kernel first
        _batch_us(fn, 50, cpu)
    times = np.empty((rounds, len(named)))
    for r in range(rounds):
        for i, (_, fn) in enumerate(named):
            times[r, i] = _batch_us(fn, batch, cpu)
    out = {}
    for i, (name, _) in enumerate(named):
        q25, med, q75 = np.percentile(times[:, i], [25, 50, 75])
        out[name] = {"median_us": float(med), "q25_us": float(q25), "q75_us": float(q75)}
    return out


def _batch_us(fn: Any, batch: int, cpu: bool) -> float:
    """µs per call of ``batch`` calls of ``fn`` (or its own timing, :func:`measure`)."""
    own = getattr(fn, "per_call_us", None)
    if own is not None:
        return float(own(batch, cpu))
    clock = time.thread_time_ns if cpu else time.perf_counter_ns
    t0 = clock()
    for _ in range(batch):
        fn()
    return (clock() - t0) / batch / 1e3


def timing_args(
    description: str, visp: bool = False
) -> tuple[argparse.Namespace, tuple[float, float, float]]:
    """The options of a timing benchmark (--rounds, --batch, --json, --clock; ``visp``:
    --visp too) and the load average, said on stderr before the timing starts."""
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
    if visp:
        parser.add_argument(
            "--laws",
            default=",".join(LAWS),
            help=f"the laws of the law and path items, comma-separated (default {','.join(LAWS)})",
        )
        parser.add_argument(
            "--visp",
            type=Path,
            metavar="PATH",
            help="ViSP's step harness (sh benchmarks/visp/build.sh), timed in the same rounds",
        )
    args = parser.parse_args()
    for name in ("rounds", "batch"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} must be a positive integer, got {getattr(args, name)}")
    load = os.getloadavg()
    print(
        f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; warming up and timing "
        f"{args.rounds} rounds x {args.batch} calls per item...",
        file=sys.stderr,
    )
    return args, load


def visp_lines(
    res: dict[str, dict[str, float]], visp_us: float = VISP_US, measured: bool = False
) -> list[str]:
    """The items with an issue-29 target as ratios to ViSP's step (``visp_us``, µs; said
    ``measured`` in this run, else issue 29's figure)."""
    source = "this run" if measured else "issue 29"
    out = []
    more = {name: 2.5 for name in res if name.startswith("path ")}
    for name, target in {**VISP_TARGETS, **more}.items():
        if name not in res:
            continue
        ratio = res[name]["median_us"] / visp_us
        mark = "met" if ratio <= target else "missed"
        out.append(
            f"{name} / ViSP ({visp_us:.2f} µs, {source}): {ratio:.2f}x "
            f"(target ≤ {target:g}x: {mark})"
        )
    return out


def with_visp(
    named: list[tuple[str, Any]], path: Path | None, case: Any
) -> tuple[list[tuple[str, Any]], Any, dict[str, float]]:
    """``named`` with ViSP's step (the harness at ``path``, None: none) appended, the
    running harness (or None) and the agreement of its numbers with redservo's.

    Raises:
        SystemExit: (code 2, one line on stderr) the harness is missing or fails.
    """
    if path is None:
        return named, None, {}
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from visp.harness import HarnessError, VispStep, agreement

    try:
        harness = VispStep(path, case)
    except (HarnessError, OSError) as err:
        print(f"bench_object_path.py: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    try:
        agree = agreement(case, harness.check())
    except HarnessError as err:
        harness.close(kill=True)
        print(f"bench_object_path.py: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    return [*named, (VISP_ITEM, harness)], harness, agree


def table(res: dict[str, dict[str, float]]) -> list[str]:
    """The markdown table of the medians, with issue 18's targets."""
    lines = ["| item (afma6-4points) | median µs | IQR µs | target |", "|---|---:|---:|---|"]
    for name, r in res.items():
        target = TARGETS_US.get(name)
        mark = (
            ""
            if target is None
            else f"≤ {target:g} ({'met' if r['median_us'] <= target else 'missed'})"
        )
        lines.append(
            f"| {name} | {r['median_us']:.1f} | {r['q25_us']:.1f}–{r['q75_us']:.1f} | {mark} |"
        )
    return lines


def ratio_lines(res: dict[str, dict[str, float]]) -> list[str]:
    """The paths and ``Controller.step`` as ratios to the compiled measured step, then the
    items with an issue-29 target as ratios to ViSP's step (measured in this run when
    ``res`` has it, else :data:`VISP_US`)."""
    compiled = res["compiled measured"]["median_us"]
    out = []
    for name in (n for n in res if n.startswith("path ")):
        out.append(f"{name} / compiled measured step: {res[name]['median_us'] / compiled:.1f}x")
    for name in ("Controller.step", "Controller.step .qdot"):
        ratio = res[name]["median_us"] / compiled
        mark = "met" if ratio <= 1.3 else "missed"
        out.append(f"{name} / compiled measured step: {ratio:.2f}x (target ≤ 1.3x: {mark})")
    visp = res.get(VISP_ITEM)
    if visp is None:
        return [*out, *visp_lines(res)]
    return [*out, *visp_lines(res, visp["median_us"], measured=True)]


def main() -> None:
    args, load = timing_args(__doc__.split("\n\n")[0], visp=True)
    case = the_case()
    laws = tuple(m.strip() for m in args.laws.split(",") if m.strip())
    try:
        named = items(case, laws)
    except RedservoError as err:  # an unknown law: one line, exit code 2
        print(f"bench_object_path.py: --laws: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    named, harness, agree = with_visp(named, args.visp, case)
    try:
        res = measure(named, args.rounds, args.batch, args.clock == "cpu")
    finally:
        if harness is not None:
            harness.close()
    end = os.getloadavg()
    print("\n".join(table(res)))
    print(f"\nload average {end[0]:.2f} {end[1]:.2f} {end[2]:.2f} at the end\n")
    print("\n".join(ratio_lines(res)))
    if harness is not None:
        print(f"\n{harness.version}: max |ViSP - redservo| on the same case:")
        for what, diff in agree.items():
            print(f"  {what}: {diff:.2e}")
    if args.json is not None:
        data = {
            "case": "afma6-4points",
            "load_avg": list(load),
            "load_avg_end": list(end),
            "rounds": args.rounds,
            "batch": args.batch,
            "clock": args.clock,
            "visp": None if harness is None else {"version": harness.version, "agreement": agree},
            "items": res,
        }
        args.json.write_text(json.dumps(data, indent=2))
        print(f"wrote {args.json}", file=sys.stderr)


if __name__ == "__main__":
    main()
