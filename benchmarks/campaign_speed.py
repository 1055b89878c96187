"""Benchmark: campaign throughput in control steps per CPU second, and local scaling.

    .venv/bin/python benchmarks/campaign_speed.py [--campaign cm01-gaze] [--samples 100] \
        [--scaling 300]
    .venv/bin/python benchmarks/campaign_speed.py --all [--samples 30] [--loop-samples 5]

prints, for a campaign (default ``cm01-gaze``, every method of its definition):

1. the compiled loop alone, per method: CPU µs per control step and steps per CPU second
   (:func:`loop_rates`, the loop kernel with its ``qp`` solver calls, without the
   sampling, the set-up and the summary of a run);
2. whole campaigns in this process (``workers=1``): control steps per CPU second and CPU ms
   per run, on the compiled loop and on the object path (:func:`campaign_rate`);
3. with ``--scaling N``: an N-sample campaign stored in a temporary directory with 1 and 2
   local worker processes: wall time, CPU time of the workers and of the client (this
   process: it stores the rows), and the speed-up (:func:`local_scaling`).

CPU time is the process's (``time.process_time``); a machine shared with other jobs still
inflates it (caches, memory bandwidth), so the load average is printed with the results.
With ``--all``: for every shipped campaign, its compiled methods, the loop alone and the
whole campaign in this process (the marginal rate: after a 1-sample warm-up), one table
(:func:`all_campaigns`; a campaign with no compiled method gets a row saying why).
docs/scaling.md gives the numbers.

Last figures (2026-11-29, issue 29 item 4, third pass: the per-sample and per-run Python
out of the way), steps per CPU second end to end, 40 samples, main (6d8acfe) / this code
alternated campaign by campaign, two rounds, load average 10.5-13.3 on 2 CPUs (absolute
numbers depressed; compare within a line), each from ``campaign_row(name, 40, 5)`` as
``--all --samples 40 --loop-samples 5`` calls it (end to end / loop alone in brackets):

* afma6-gaze-demo 48 300 / 43 400 (0.42 / 0.38) → 58 400 / 62 000 (0.55 / 0.57)
* cm01-gaze 79 200 / 76 400 (0.75 / 0.71) → 94 800 / 94 500 (0.88 / 0.87)
* cm01-humanoid-tracking 58 100 / 57 700 (0.83 / 0.84) → 62 400 / 62 700 (0.90 / 0.91)
* mc05-joint-limits 44 400 / 45 700 (0.80 / 0.79) → 49 100 / 47 400 (0.86 / 0.84)
* panda-near-limits 46 000 / 47 200 (0.69 / 0.68) → 48 100 / 50 600 (0.74 / 0.79)
* panda-urdf-near-limits 45 400 / 45 200 (0.64 / 0.63) → 52 600 / 52 000 (0.73 / 0.75)
* panda-posts 27 100 / 28 300 (0.88 / 0.91) → 28 400 / 28 500 (0.90 / 0.92)

Still below 100 000 end to end: cm01-gaze within 6 % of it (its loop alone: 107 000); the
loop alone is below it wherever ``J1`` has 6 rows or more (LAPACK ``dgesvd`` of a 6x6
matrix: 5.3 µs per step, kept: it is every law's SVD on every path); docs/scaling.md says
where the rest goes.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Sequence
from typing import Any, NamedTuple

__all__ = [
    "CampaignRate",
    "Scaling",
    "all_campaigns",
    "campaign_rate",
    "campaign_row",
    "local_scaling",
    "loop_rates",
    "main",
]


class CampaignRate(NamedTuple):
    """Throughput of a campaign run in this process."""

    runs: int
    steps: int
    """Control steps (sum of the runs' iterations)."""
    cpu_s: float
    wall_s: float

    @property
    def steps_per_cpu_s(self) -> float:
        return self.steps / self.cpu_s

    @property
    def cpu_ms_per_run(self) -> float:
        return 1e3 * self.cpu_s / self.runs


def campaign_rate(
    campaign: str, samples: int, *, fast: bool = True, methods: Sequence[str] | None = None
) -> CampaignRate:
    """Run ``samples`` samples in this process (after a 1-sample warm-up) and time them."""
    from redservo.campaign import load_campaign, run_campaign

    defn = load_campaign(campaign)
    run_campaign(defn, samples=1, methods=methods, workers=1, progress=False, fast=fast)
    wall, cpu = time.perf_counter(), time.process_time()
    res = run_campaign(defn, samples=samples, methods=methods, workers=1, progress=False, fast=fast)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    steps = sum(int(r["iterations"]) for r in res.rows)
    return CampaignRate(len(res.rows), steps, cpu, wall)


def loop_rates(campaign: str, samples: int, repeat: int = 3) -> dict[str, tuple[float, int]]:
    """Per method: CPU seconds per control step of the compiled loop alone, and the steps
    timed (``samples`` samples, each run ``repeat`` times)."""
    from redservo.campaign import draw_sample, load_campaign
    from redservo.experiment.build import build
    from redservo.kernels.blas import one_blas_thread

    defn = load_campaign(campaign)
    exps = [build(draw_sample(defn, 0, i).scenario) for i in range(samples)]
    with one_blas_thread():  # as the campaign's jobs run (campaign/task.py run_job)
        return _loop_rates(defn, exps, repeat)


def _loop_rates(defn: Any, exps: list[Any], repeat: int) -> dict[str, tuple[float, int]]:
    """:func:`loop_rates` on built experiments."""
    from redservo.campaign.fastloop import (
        _buffers,
        _law_args,
        _packed,
        _run_loop,
        campaign_law,
        fast_reason,
    )
    from redservo.campaign.loop_avoid import collision_pack

    out: dict[str, tuple[float, int]] = {}
    for method in defn.methods:
        cpu, steps = 0.0, 0
        for exp in exps:
            law = campaign_law(exp, method, defn.method_options.get(method))
            if fast_reason(exp, law) is not None:  # e.g. predictive: the Python step
                break
            p = _packed(exp)
            assert not isinstance(p, str), p
            logs = _buffers(exp.options.max_iterations, exp.robot.n)
            la = _law_args(law, exp.robot.n)
            args = (p.robot, p.scene, p.task, la, p.limits, p.sim, logs, collision_pack(exp, law))
            _run_loop(exp, law, args)  # warm-up (compile or load, first solver import)
            t = time.process_time()
            for _ in range(repeat):
                rows = _run_loop(exp, law, args)[0]
            cpu += (time.process_time() - t) / repeat
            steps += rows
        if steps:
            out[method] = (cpu / steps, steps)
    return out


class Scaling(NamedTuple):
    """One local campaign: wall time, and CPU time of this process (the client: sampling
    nothing, storing rows) and of its worker processes."""

    workers: int
    wall_s: float
    client_cpu_s: float
    worker_cpu_s: float
    runs: int


def _cpu(who: int) -> float:
    import resource

    r = resource.getrusage(who)
    return float(r.ru_utime + r.ru_stime)


def local_scaling(
    campaign: str, samples: int, workers: Sequence[int] = (1, 2), out: str | None = None
) -> list[Scaling]:
    """Wall and CPU seconds of a ``samples``-sample campaign per number of local workers
    (rows stored in a fresh directory under ``out``, or a temporary one, as a user would)."""
    import resource
    import tempfile

    from redservo.campaign import load_campaign, run_campaign

    defn = load_campaign(campaign)
    run_campaign(defn, samples=1, workers=1, progress=False)
    res: list[Scaling] = []
    with tempfile.TemporaryDirectory(dir=out) as tmp:
        for w in workers:
            wall = time.perf_counter()
            me, kids = _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_CHILDREN)
            r = run_campaign(defn, samples=samples, workers=w, progress=False, out=f"{tmp}/{w}")
            wall = time.perf_counter() - wall
            me, kids = _cpu(resource.RUSAGE_SELF) - me, _cpu(resource.RUSAGE_CHILDREN) - kids
            if w == 1:  # the runs are in this process: no separate client
                me, kids = 0.0, me
            res.append(Scaling(w, wall, me, kids, len(r.rows)))
    return res


def dask_scaling(campaign: str, samples: int, workers: Sequence[int] = (1, 2)) -> list[Scaling]:
    """Wall seconds of a ``samples``-sample campaign (rows stored) on a local Dask cluster of
    ``w`` one-thread worker processes, for each ``w`` (the workers are started and warmed up
    with a 1-sample campaign first; client CPU is this process's)."""
    import resource
    import tempfile

    from distributed import LocalCluster

    from redservo.campaign import load_campaign, run_campaign

    defn = load_campaign(campaign)
    res: list[Scaling] = []
    with tempfile.TemporaryDirectory() as tmp:
        for w in workers:
            with LocalCluster(
                n_workers=w, threads_per_worker=1, processes=True, dashboard_address=None
            ) as cluster:
                address = cluster.scheduler_address
                run_campaign(defn, samples=w, scheduler=address, progress=False)
                wall, me = time.perf_counter(), _cpu(resource.RUSAGE_SELF)
                r = run_campaign(
                    defn, samples=samples, scheduler=address, progress=False, out=f"{tmp}/{w}"
                )
                wall, me = time.perf_counter() - wall, _cpu(resource.RUSAGE_SELF) - me
            res.append(Scaling(w, wall, me, float("nan"), len(r.rows)))
    return res


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover - not on every platform
        return "n/a"


def main(argv: Sequence[str] | None = None) -> int:
    """Print the measurements of the module docstring."""
    p = argparse.ArgumentParser(prog="python benchmarks/campaign_speed.py", description=__doc__)
    p.add_argument("--campaign", default="cm01-gaze")
    p.add_argument("--samples", type=int, default=100, help="samples of the campaign rates")
    p.add_argument("--loop-samples", type=int, default=10, help="samples of the loop rates")
    p.add_argument("--object-samples", type=int, default=5, help="samples on the object path")
    p.add_argument("--scaling", type=int, default=0, help="samples of the 1-vs-2-worker run")
    p.add_argument("--dask", type=int, default=0, help="samples of the 1-vs-2 Dask-worker run")
    p.add_argument("--skip-rates", action="store_true", help="only the scaling runs")
    p.add_argument("--all", action="store_true", help="every shipped campaign, one table")
    a = p.parse_args(argv)
    if a.all:
        all_campaigns(a.samples, a.loop_samples)
        return 0
    print(f"campaign {a.campaign}; load average {_load()} on {os.cpu_count()} CPUs")
    if not a.skip_rates:
        _rates(a)
    if a.scaling:
        print(f"\nlocal worker processes, {a.scaling} samples, rows stored (figures included):")
        res = local_scaling(a.campaign, a.scaling)
        for r in res:
            print(f"  workers={r.workers}: wall {r.wall_s:7.1f} s, worker CPU {r.worker_cpu_s:7.1f} s, "
                  f"client CPU {r.client_cpu_s:6.1f} s "
                  f"({1e3 * r.client_cpu_s / r.runs:.3f} ms per row)")  # fmt: skip
        print(f"  speed-up 1 -> 2 workers: {res[0].wall_s / res[1].wall_s:.2f}")
    if a.dask:
        print(f"\nlocal Dask cluster (one-thread worker processes), {a.dask} samples, rows stored:")
        res = dask_scaling(a.campaign, a.dask)
        for r in res:
            print(
                f"  workers={r.workers}: wall {r.wall_s:7.1f} s, client CPU {r.client_cpu_s:6.1f} s"
            )
        print(f"  speed-up 1 -> 2 workers: {res[0].wall_s / res[1].wall_s:.2f}")
    print(f"load average after: {_load()}")
    return 0


def all_campaigns(samples: int, loop_samples: int) -> None:
    """Print, per shipped campaign (its methods the compiled loop runs): the loop alone and
    the whole campaign in this process, in steps per CPU second, and their ratio."""
    from redservo.campaign.definition import shipped_campaigns

    print(f"load average {_load()} on {os.cpu_count()} CPUs; {samples} samples per campaign")
    print("| campaign | runs | steps | loop alone | end to end | end to end / loop |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in sorted(shipped_campaigns()):
        print(campaign_row(name, samples, loop_samples), flush=True)
    print(f"load average after: {_load()}")


def campaign_row(name: str, samples: int, loop_samples: int) -> str:
    """The table row of :func:`all_campaigns` for campaign ``name``."""
    rates = loop_rates(name, loop_samples)
    if not rates:  # e.g. obstacles: every run on the object path (the loop measures no distance)
        return f"| {name} | no method on the compiled loop: {_uncovered(name)} | | | | |"
    cpu = sum(per_step * steps for per_step, steps in rates.values())
    loop = sum(steps for _, steps in rates.values()) / cpu
    r = campaign_rate(name, samples, methods=list(rates))
    end = r.steps_per_cpu_s
    return f"| {name} | {r.runs} | {r.steps} | {loop:,.0f} | {end:,.0f} | {end / loop:.2f} |"


def _uncovered(name: str) -> str:
    """Why the first sample of campaign ``name`` does not run on the compiled loop."""
    from redservo.campaign import draw_sample, load_campaign
    from redservo.campaign.fastloop import experiment_reason
    from redservo.experiment.build import build

    return str(experiment_reason(build(draw_sample(load_campaign(name), 0, 0).scenario)))


def _rates(a: argparse.Namespace) -> None:
    print("\ncompiled loop alone (CPU µs per step, steps per CPU s):")
    total_cpu = total_steps = 0.0
    rates = loop_rates(a.campaign, a.loop_samples)
    for method, (per_step, steps) in rates.items():
        total_cpu, total_steps = total_cpu + per_step * steps, total_steps + steps
        print(f"  {method:20s} {per_step * 1e6:6.2f} µs  {1 / per_step:9.0f}  ({steps} steps)")
    print(f"  {'all methods':20s} {total_cpu / total_steps * 1e6:6.2f} µs  "
          f"{total_steps / total_cpu:9.0f}")  # fmt: skip
    methods = list(rates)  # the methods the compiled loop runs (not predictive's Python step)
    rows: list[tuple[str, Any]] = [
        ("compiled loop", campaign_rate(a.campaign, a.samples, methods=methods)),
        ("object path", campaign_rate(a.campaign, a.object_samples, fast=False, methods=methods)),
    ]
    print("\nwhole campaign in one process (sampling, set-up, runs, summaries, rows):")
    for name, r in rows:
        print(f"  {name:14s} {r.runs:6d} runs {r.steps:9d} steps  {r.steps_per_cpu_s:9.0f} "
              f"steps per CPU s  {r.cpu_ms_per_run:7.2f} CPU ms per run")  # fmt: skip


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
