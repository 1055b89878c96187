"""Benchmark: where the obstacles' share of a compiled campaign step goes, and the rates.

    .venv/bin/python benchmarks/collision_profile.py [--campaign panda-posts] [--samples 8] \
        [--reps 5] [--rounds 2] [--campaign-samples 10] [--skip-profile] [--all-methods]

For each compiled method of the campaign (``qp`` and ``sns`` with their damper rows too),
runs its first ``--samples`` samples on the compiled loop, keeps every visited ``q`` and
command, and replays them through compiled timing loops (numba, ``--reps`` passes; CPU µs per
control step, ``time.process_time``):

* ``points``: :func:`redservo.kernels.loop_collide.dh_points` (frame origins, Jacobians);
* ``bounds``: ``points`` and :func:`redservo.kernels.loop_cull.pair_bounds`;
* ``culled``: :func:`redservo.kernels.loop_cull.measure_culled` (what step 1 computes);
* ``full``: :func:`redservo.kernels.loop_collide.measure_arm` (every pair);
* ``avoid``: the loop's three collision steps on the visited states
  (:mod:`redservo.kernels.loop_avoid`: the check, the repulsion, the shield and its check on
  the logged command), with a fresh pack per run as the loop has;
* ``searches/step``, ``pairs/step``: the capsule/box and capsule/cylinder pairs, and all
  pairs, that step 1 computes (:func:`~redservo.kernels.loop_cull.measure_culled`).

Then the steps the loop hands back to the law in Python (:mod:`redservo.campaign.loop_handback`:
none since ``qp`` and ``sns`` solve their damper rows in the loop; a ``qp`` with a Python
solver library would), per method, and
``--rounds`` times alternated in the same minutes: the loop alone (steps per CPU s) on the
same samples with obstacles and without (``obstacles = []``, ``collision.enabled = false``:
the obstacle-free campaign), and the whole campaign in this process (``workers=1``,
``--campaign-samples`` samples after a 1-sample warm-up; the compiled methods, or with
``--all-methods`` every method of the campaign, ``predictive``'s Python step included), with
and without obstacles, and the reachability search of those samples alone (its obstacle
stage, :mod:`redservo.campaign.reach_obstacles`, is part of the campaign's cost). Last, the
whole campaign of ``qp`` and ``sns`` with their rows on the loop against the object path
(``fast=False``), alternated. docs/scaling.md gives the numbers.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit

from redservo.kernels.loop_avoid import collide_check, secondary, shield_step
from redservo.kernels.loop_collide import dh_points, measure_arm
from redservo.kernels.loop_cull import measure_culled, pair_bounds

sys.path.insert(0, str(Path(__file__).resolve().parent))
from campaign_speed import _load, _loop_rates

__all__ = ["main", "profile"]


@njit
def _t_points(Q: Any, arm: Any, reps: int) -> float:
    acc = 0.0
    for _ in range(reps):
        for i in range(Q.shape[0]):
            acc += dh_points(Q[i], arm)[0][1, 0]
    return acc


@njit
def _t_bounds(Q: Any, arm: Any, geom: Any, reps: int) -> float:
    acc = 0.0
    for _ in range(reps):
        for i in range(Q.shape[0]):
            acc += pair_bounds(dh_points(Q[i], arm)[0], geom)[0]
    return acc


@njit
def _t_culled(Q: Any, arm: Any, geom: Any, d_i: float, reps: int) -> float:
    acc = 0.0
    for _ in range(reps):
        for i in range(Q.shape[0]):
            acc += measure_culled(Q[i], arm, geom, d_i)[2][0]
    return acc


@njit
def _t_full(Q: Any, arm: Any, geom: Any, reps: int) -> float:
    acc = 0.0
    for _ in range(reps):
        for i in range(Q.shape[0]):
            acc += measure_arm(Q[i], arm, geom)[0][0]
    return acc


@njit
def _avoid(Q: Any, QD: Any, coll: Any) -> float:
    """The loop's collision steps along a visited trajectory (one pass)."""
    acc = 0.0
    prev = np.zeros(Q.shape[1])
    for i in range(Q.shape[0]):
        d, J, _ = collide_check(i, Q[i], coll, True)
        sec = secondary(d, J, coll)
        qd, _ = shield_step(Q[i], QD[i], 0, prev, d, J, coll)
        prev = QD[i]
        acc += qd[0] + (sec[0] if sec.shape[0] else 0.0)
    return acc


def _t_avoid(Q: Any, QD: Any, exp: Any, law: Any, reps: int) -> float:
    """``reps`` passes of :func:`_avoid`, each with a fresh pack (the loop's, per run)."""
    from redservo.campaign.loop_avoid import collision_pack

    return sum(_avoid(Q, QD, collision_pack(exp, law)) for _ in range(reps))


def _states(exp: Any, law: Any) -> tuple[Any, Any, Any] | None:
    """Run ``law`` on ``exp`` in the loop; the visited ``q``, commands, and the pack."""
    from redservo.campaign.fastloop import _buffers, _law_args, _packed, _run_loop, fast_reason
    from redservo.campaign.loop_avoid import collision_pack

    if fast_reason(exp, law) is not None:
        return None
    p = _packed(exp)
    assert not isinstance(p, str), p
    logs = _buffers(exp.options.max_iterations, exp.robot.n)
    coll = collision_pack(exp, law)
    args = (p.robot, p.scene, p.task, _law_args(law, exp.robot.n), p.limits, p.sim, logs, coll)
    rows = _run_loop(exp, law, args)[0]
    return logs[0][:rows].copy(), logs[1][:rows].copy(), coll


def _timed(fn: Any, *args: Any) -> float:
    """CPU seconds of ``fn(*args)`` after a first call (compile or load)."""
    fn(*args)
    t = time.process_time()
    fn(*args)
    return time.process_time() - t


def _searches(Q: Any, coll: Any) -> tuple[int, int]:
    """Capsule/box-or-cylinder pairs and all pairs computed by step 1 over ``Q``."""
    from redservo.kernels.loop_collide import BOX, CYLINDER

    geom, d_i = coll[2], float(coll[3][1])
    C = geom[0].shape[0]
    kinds = np.repeat(geom[2], C)
    solid = (kinds == BOX) | (kinds == CYLINDER)
    n_solid = n_all = 0
    for q in Q:
        d = measure_culled(q, coll[1], geom, d_i)[0]
        done = d[: kinds.shape[0]] != np.inf
        n_solid += int(np.sum(done & solid))
        n_all += int(np.sum(d != np.inf))
    return n_solid, n_all


def profile(defn: Any, samples: int, reps: int) -> None:
    """The component table of the module docstring."""
    from redservo.campaign import draw_sample
    from redservo.campaign.fastloop import campaign_law
    from redservo.experiment.build import build

    exps = [build(draw_sample(defn, 0, i).scenario) for i in range(samples)]
    print(
        "| method | steps | points | bounds | culled | full | avoid | searches/step | pairs/step |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for method in defn.methods:
        tot, steps, srch, pairs = np.zeros(5), 0, 0, 0
        for exp in exps:
            law = campaign_law(exp, method, defn.method_options.get(method))
            st = _states(exp, law)
            if st is None:
                break
            Q, QD, coll = st
            arm, geom, d_i = coll[1], coll[2], float(coll[3][1])
            tot += [
                _timed(_t_points, Q, arm, reps) / reps,
                _timed(_t_bounds, Q, arm, geom, reps) / reps,
                _timed(_t_culled, Q, arm, geom, d_i, reps) / reps,
                _timed(_t_full, Q, arm, geom, reps) / reps,
                _timed(_t_avoid, Q, QD, exp, law, reps) / reps,
            ]
            s, a = _searches(Q, coll)
            srch, pairs, steps = srch + s, pairs + a, steps + Q.shape[0]
        if steps:
            cols = " | ".join(f"{x:.2f}" for x in 1e6 * tot / steps)
            print(f"| {method} | {steps} | {cols} | {srch / steps:.2f} | {pairs / steps:.2f} |")


def _rate(defn: Any, samples: int, methods: list[str]) -> float:
    """Steps per CPU second of the compiled loop alone over ``samples`` samples."""
    from redservo.campaign import draw_sample
    from redservo.experiment.build import build
    from redservo.kernels.blas import one_blas_thread

    exps = [build(draw_sample(defn, 0, i).scenario) for i in range(samples)]
    with one_blas_thread():
        rates = _loop_rates(replace(defn, methods=methods), exps, 2)
    cpu = sum(per * steps for per, steps in rates.values())
    return sum(steps for _, steps in rates.values()) / cpu


def _campaign_rate(defn: Any, samples: int, methods: list[str]) -> float:
    """Steps per CPU second of ``samples`` samples of the campaign in this process, after a
    1-sample warm-up (``benchmarks/campaign_speed.py``'s ``campaign_rate`` on a definition)."""
    from redservo.campaign import run_campaign

    run_campaign(defn, samples=1, methods=methods, workers=1, progress=False)
    cpu = time.process_time()
    res = run_campaign(defn, samples=samples, methods=methods, workers=1, progress=False)
    cpu = time.process_time() - cpu
    return sum(int(r["iterations"]) for r in res.rows) / cpu


def _object_rate(defn: Any, samples: int, methods: list[str]) -> float:
    """:func:`_campaign_rate` with every run on the object path (``fast=False``)."""
    from redservo.campaign import run_campaign

    run_campaign(defn, samples=1, methods=methods, workers=1, progress=False, fast=False)
    cpu = time.process_time()
    res = run_campaign(
        defn, samples=samples, methods=methods, workers=1, progress=False, fast=False
    )
    cpu = time.process_time() - cpu
    return sum(int(r["iterations"]) for r in res.rows) / cpu


def rows_on_loop(defn: Any, samples: int, rounds: int) -> None:
    """``qp`` and ``sns`` avoiding, whole campaigns: on the loop and on the object path (where
    they ran before their rows were built in the loop), alternated."""
    pair = ["qp", "sns"]
    for r in range(rounds):
        loop, obj = _campaign_rate(defn, samples, pair), _object_rate(defn, samples, pair)
        print(f"  qp,sns round {r + 1}: {loop:,.0f} on the loop, {obj:,.0f} on the object path")


def _reach_cpu(defn: Any, samples: int) -> float:
    """CPU seconds of the reachability search of samples 1 … ``samples`` (sample 0 warms up;
    with obstacles: :mod:`redservo.campaign.reach_obstacles`)."""
    from redservo.campaign import draw_sample
    from redservo.campaign.reach import reachable
    from redservo.experiment.build import build
    from redservo.kernels.blas import one_blas_thread

    exps = [build(draw_sample(defn, 0, i).scenario) for i in range(samples + 1)]
    with one_blas_thread():
        reachable(exps[0])
        cpu = time.process_time()
        for exp in exps[1:]:
            reachable(exp)
        return time.process_time() - cpu


def _compiled_methods(defn: Any) -> list[str]:
    """The methods whose first sample runs on the compiled loop."""
    from redservo.campaign import draw_sample
    from redservo.campaign.fastloop import campaign_law, fast_reason
    from redservo.experiment.build import build

    exp = build(draw_sample(defn, 0, 0).scenario)
    m = defn.methods
    return [
        x for x in m if fast_reason(exp, campaign_law(exp, x, defn.method_options.get(x))) is None
    ]


def hand_backs(defn: Any, free: Any, samples: int, methods: list[str]) -> None:
    """Per method, on the loop alone over ``samples`` samples: the steps it hands back to
    Python, and its steps per CPU s with obstacles and without (``free``)."""
    from redservo.campaign import draw_sample, loop_handback
    from redservo.experiment.build import build
    from redservo.kernels.blas import one_blas_thread

    def built(d: Any) -> list[Any]:
        return [build(draw_sample(d, 0, i).scenario) for i in range(samples)]

    counts: dict[str, int] = {}
    step = loop_handback.python_step

    def counted(exp: Any, law: Any, *args: Any) -> None:
        counts[law.name] = counts.get(law.name, 0) + 1
        step(exp, law, *args)

    loop_handback.python_step = counted
    try:
        with one_blas_thread():
            rates = _loop_rates(replace(defn, methods=methods), built(defn), 1)
    finally:
        loop_handback.python_step = step
    with one_blas_thread():
        rates_free = _loop_rates(replace(free, methods=methods), built(free), 1)
    for method, (per, steps) in rates.items():
        k = counts.get(method, 0) // 2  # _loop_rates runs each sample twice (a warm-up)
        rf = 1.0 / rates_free[method][0]
        print(
            f"  {method}: {k} of {steps} steps handed back to Python ({100 * k / steps:.1f} %); "
            f"{1.0 / per:,.0f} steps per CPU s with obstacles, {rf:,.0f} without"
        )


def rates(
    defn: Any, free: Any, samples: int, campaign_samples: int, rounds: int, every: bool
) -> None:
    """Loop alone and whole campaign, with and without obstacles, alternated; ``every``:
    the whole campaign with every method, not only the compiled ones."""
    methods = _compiled_methods(defn)
    print(f"compiled methods with obstacles: {', '.join(methods)}")
    hand_backs(defn, free, samples, methods)
    whole = list(defn.methods) if every else methods
    for r in range(rounds):
        print(f"round {r + 1}: load average {_load()}")
        loop, loop_free = _rate(defn, samples, methods), _rate(free, samples, methods)
        share = 100 * loop / loop_free
        print(f"  loop alone: {loop:,.0f} with obstacles, {loop_free:,.0f} without ({share:.0f} %)")
        if campaign_samples:
            c = _campaign_rate(defn, campaign_samples, whole)
            cf = _campaign_rate(free, campaign_samples, whole)
            share = 100 * c / cf
            print(f"  whole campaign: {c:,.0f} with obstacles, {cf:,.0f} without ({share:.0f} %)")
            r, rf = _reach_cpu(defn, campaign_samples), _reach_cpu(free, campaign_samples)
            print(f"  reachability search: {r:.3f} CPU s with obstacles, {rf:.3f} without")


def main(argv: Sequence[str] | None = None) -> int:
    from redservo.campaign import load_campaign
    from redservo.scenario import apply_overrides

    p = argparse.ArgumentParser(prog="python benchmarks/collision_profile.py", description=__doc__)
    p.add_argument("--campaign", default="panda-posts")
    p.add_argument("--samples", type=int, default=8)
    p.add_argument("--campaign-samples", type=int, default=10)
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--skip-profile", action="store_true")
    p.add_argument("--all-methods", action="store_true")
    a = p.parse_args(argv)
    defn = load_campaign(a.campaign)
    off = ["obstacles=[]", "collision.enabled=false"]
    free = replace(defn, scenario=apply_overrides(defn.scenario, off))
    print(f"{a.campaign}: load average {_load()} on {os.cpu_count()} CPUs")
    if not a.skip_profile:
        print(f"CPU µs per step, {a.samples} samples")
        profile(defn, a.samples, a.reps)
    rates(defn, free, a.samples, a.campaign_samples, a.rounds, a.all_methods)
    if a.campaign_samples:
        rows_on_loop(defn, a.campaign_samples, a.rounds)
    print(f"load average after: {_load()}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
