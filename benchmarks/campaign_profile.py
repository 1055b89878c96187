"""Benchmark: where a compiled campaign step spends its CPU time, component by component.

    .venv/bin/python benchmarks/campaign_profile.py [--campaign mc05-joint-limits] \
        [--samples 3] [--methods classical,gpm] [--reps 20]

For each method, runs the first ``--samples`` samples of the campaign on the compiled loop,
keeps every visited state (``q``, the previous command, ``J1``, ``e1``, the feed-forward), then
replays the states through compiled timing loops (numba, ``--reps`` passes; the numbers are
CPU µs per control step, ``time.process_time``):

* ``kinematics``: :func:`redservo.kernels.robot.robot_kinematics`;
* ``sense``: kinematics, features and ``L``, CM01 eq. 25 and the known feed-forward
  (:func:`redservo.kernels.sensed.sense`); ``sense - kinematics`` is the task's share;
* ``svd``: one :func:`redservo.kernels.linalg.task_svd` of ``J1`` (the law calls it at least
  once);
* ``law+safety``: :func:`redservo.kernels.sensed.law_bits` (the law, its safety layer and
  the event bits; ``qp``: :func:`~redservo.kernels.sensed.qp_law`);
* ``loop``: the whole compiled loop (:func:`redservo.campaign.loop_kernel.closed_loop`),
  whose rest (``loop - sense - law``) is the row logging, limit tests and call overhead;
* ``end to end``: the campaign in this process (``run_campaign``, ``workers=1``) per step,
  whose rest (``end to end - loop``) is the per-sample Python: draw, start check, build,
  reachability, summary and row.

With ``--split``: only the whole campaign (``--samples`` samples after a 1-sample
warm-up), its CPU time split into the loop kernel's calls and the rest, per run and per
sample (:func:`campaign_split`).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import njit

from redservo.kernels.linalg import task_svd
from redservo.kernels.robot import robot_kinematics
from redservo.kernels.sensed import law_bits, qp_law, sense

__all__ = ["campaign_split", "main", "profile_campaign"]


@njit
def _t_kin(Q: Any, robot: Any, reps: int) -> float:
    acc = 0.0
    for _ in range(reps):
        for i in range(Q.shape[0]):
            acc += robot_kinematics(Q[i], robot)[1][0, 0]
    return acc


@njit
def _t_sense(Q: Any, robot: Any, scene: Any, task: Any, sim: Any, reps: int) -> float:
    acc = 0.0
    for _ in range(reps):
        for i in range(Q.shape[0]):
            acc += sense(i, Q[i], robot, scene, task, sim)[1][0]
    return acc


@njit
def _t_svd(J1s: Any, rcond: float, robust: float, reps: int) -> float:
    acc = 0.0
    for _ in range(reps):
        for i in range(J1s.shape[0]):
            acc += task_svd(J1s[i], rcond, robust)[1][0]
    return acc


@njit
def _t_law(*args: Any) -> float:
    J1s, e1s, ffs, has_ff, Q, P, law, limits, sim, reps = args
    acc = 0.0
    none = Q[0][:0]
    for _ in range(reps):
        for i in range(J1s.shape[0]):
            args = (J1s[i], e1s[i], ffs[i], has_ff, Q[i], P[i], none, False)
            acc += law_bits(*args, law, limits, sim)[0][0]
    return acc


@njit
def _t_qp(*args: Any) -> float:
    J1s, e1s, ffs, has_ff, Q, P, law, limits, sim, solve, reps = args
    acc = 0.0
    for _ in range(reps):
        for i in range(J1s.shape[0]):
            args = (J1s[i], e1s[i], ffs[i], has_ff, Q[i], P[i])
            acc += qp_law(*args, law, limits, sim, solve)[0][0]
    return acc


def _states(exp: Any, law: Any) -> tuple[Any, ...] | None:
    """Run ``law`` on ``exp`` in the loop; the visited states and the loop's CPU time."""
    from redservo.campaign.fastloop import _buffers, _law_args, _packed, _run_loop
    from redservo.campaign.loop_avoid import collision_pack

    p = _packed(exp)
    if isinstance(p, str):
        return None
    logs = _buffers(exp.options.max_iterations, exp.robot.n)
    la = _law_args(law, exp.robot.n)
    args = (p.robot, p.scene, p.task, la, p.limits, p.sim, logs, collision_pack(exp, law))
    _run_loop(exp, law, args)
    t = time.process_time()
    rows = _run_loop(exp, law, args)[0]
    cpu = time.process_time() - t
    Q = logs[0][:rows].copy()
    P = np.vstack([np.zeros((1, exp.robot.n)), logs[1][: rows - 1]])
    J1s, e1s, ffs = [], [], []
    for i in range(rows):
        _, e1, J1, ff, _, _, _ = sense(i, Q[i], p.robot, p.scene, p.task, p.sim)
        J1s.append(J1)
        e1s.append(e1)
        ffs.append(ff)
    return p, la, Q, P, np.array(J1s), np.array(e1s), np.array(ffs), cpu


def _timed(fn: Any, *args: Any) -> float:
    """CPU seconds of ``fn(*args)`` after a first call (compile or load)."""
    fn(*args)
    t = time.process_time()
    fn(*args)
    return time.process_time() - t


def _component_times(states: tuple[Any, ...], rcond: float, reps: int) -> list[float]:
    """CPU seconds per pass of kinematics, sense, one SVD, the law and the loop."""
    p, la, Q, P, J1s, e1s, ffs, loop_cpu = states
    has_ff = bool(p.sim[6])
    times = [
        _timed(_t_kin, Q, p.robot, reps),
        _timed(_t_sense, Q, p.robot, p.scene, p.task, p.sim, reps),
        _timed(_t_svd, J1s, rcond, 0.0, reps),
    ]
    law_args = (J1s, e1s, ffs, has_ff, Q, P, la, p.limits, p.sim)
    if la[0] < 0:  # qp
        m, n = J1s.shape[1:]
        pend = np.zeros(4, dtype=np.int64)
        solve = (np.zeros((m, n)), np.zeros(m), np.zeros(n), pend, np.zeros(m))
        times.append(_timed(_t_qp, *law_args, solve, reps))
    else:
        times.append(_timed(_t_law, *law_args, reps))
    return [t / reps for t in times] + [loop_cpu]


def profile_campaign(name: str, samples: int, methods: Sequence[str] | None, reps: int) -> None:
    """Print the table of the module docstring for campaign ``name``."""
    from redservo.campaign import draw_sample, load_campaign, run_campaign
    from redservo.campaign.fastloop import campaign_law, fast_reason
    from redservo.experiment.build import build
    from redservo.kernels.blas import one_blas_thread

    defn = load_campaign(name)
    exps = [build(draw_sample(defn, 0, i).scenario) for i in range(samples)]
    ms = list(methods or defn.methods)
    print(f"{name}: {samples} samples, CPU µs per step")
    print("| method | steps | kinematics | sense | svd | law+safety | loop | rest of loop |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    fast = []
    with one_blas_thread():
        for method in ms:
            tot = np.zeros(6)
            steps = 0
            for exp in exps:
                law = campaign_law(exp, method, defn.method_options.get(method))
                if fast_reason(exp, law) is not None:
                    break
                st = _states(exp, law)
                if st is None:
                    break
                times = _component_times(st, float(getattr(law, "rcond", 1e-8)), reps)
                Q = st[2]
                tot[:5] += times
                steps += Q.shape[0]
            if not steps:
                continue
            fast.append(method)
            us = 1e6 * tot[:5] / steps
            rest = us[4] - us[1] - us[3]
            cols = " | ".join(f"{x:.2f}" for x in (*us, rest))
            print(f"| {method} | {steps} | {cols} |", flush=True)
        run_campaign(defn, samples=1, methods=fast, workers=1, progress=False)
        t = time.process_time()
        res = run_campaign(defn, samples=samples, methods=fast, workers=1, progress=False)
        cpu = time.process_time() - t
    steps = sum(int(r["iterations"]) for r in res.rows)
    runs = len(res.rows)
    print(
        f"end to end: {1e6 * cpu / steps:.2f} µs per step ({steps / cpu:,.0f} steps per CPU s, "
        f"{steps} steps, {runs} runs, {1e3 * cpu / runs:.2f} CPU ms per run)"
    )


def campaign_split(name: str, samples: int, methods: Sequence[str] | None) -> None:
    """Print the CPU time of a campaign in this process (after a 1-sample warm-up) split
    into the loop kernel's calls and the rest (the per-sample and per-run Python: draw,
    build, start check, reachability, packs, summaries, rows, statistics)."""
    import redservo.campaign.loop_kernel as loop_kernel
    from redservo.campaign import load_campaign, run_campaign

    defn = load_campaign(name)
    run_campaign(defn, samples=1, methods=methods, workers=1, progress=False)
    real, inside = loop_kernel.closed_loop, [0.0]

    def timed(*args: Any) -> Any:
        t = time.process_time()
        try:
            return real(*args)
        finally:
            inside[0] += time.process_time() - t

    loop_kernel.closed_loop = timed  # fastloop looks it up at each run
    try:
        t = time.process_time()
        res = run_campaign(defn, samples=samples, methods=methods, workers=1, progress=False)
        cpu = time.process_time() - t
    finally:
        loop_kernel.closed_loop = real
    steps, runs = sum(int(r["iterations"]) for r in res.rows), len(res.rows)
    rest = cpu - inside[0]
    print(
        f"{name}: {runs} runs, {steps} steps; end to end {steps / cpu:,.0f} steps per CPU s, "
        f"the loop kernel {steps / inside[0]:,.0f} ({100 * inside[0] / cpu:.0f} % of the CPU); "
        f"the rest {1e3 * rest:.1f} ms: {1e6 * rest / runs:.0f} µs per run, "
        f"{1e3 * rest / samples:.2f} ms per sample"
    )


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python benchmarks/campaign_profile.py", description=__doc__)
    p.add_argument("--campaign", default="mc05-joint-limits")
    p.add_argument("--samples", type=int, default=3)
    p.add_argument("--methods", default="")
    p.add_argument("--reps", type=int, default=20)
    p.add_argument("--split", action="store_true", help="only the loop / rest split")
    a = p.parse_args(argv)
    methods = [m for m in a.methods.split(",") if m] or None
    if a.split:
        campaign_split(a.campaign, a.samples, methods)
        return 0
    profile_campaign(a.campaign, a.samples, methods, a.reps)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
