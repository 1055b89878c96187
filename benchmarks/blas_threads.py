"""Benchmark: the compiled step at n joints on a loaded machine, BLAS threads free or pinned.

    .venv/bin/python benchmarks/blas_threads.py [--n 100] [--calls 400] [--burners 2] \
        [--methods iterative-smooth large-projection classical]

Times the compiled control step (the campaign loop's iteration,
:func:`redservo.bench.sensed.sensed_iteration`) of the 4-point
task on a seeded chain of ``n`` revolute joints (:func:`redservo.bench.cases.scaling_case`)
while ``burners`` processes spin on the CPUs (the load of a shared machine; default one per
CPU, at the lowest priority so that the machine's other users keep theirs), per method, twice, the rounds interleaved:

* ``free``: the BLAS inside the kernels as the libraries start (one thread per core);
* ``pinned``: inside :func:`redservo.kernels.blas.one_blas_thread`, as the campaign jobs,
  ``simulate`` and the servo loop run it.

Prints the median, 90th percentile and mean of the CPU time of one step (µs, the process's
CPU: the BLAS threads' included; the mean is what a campaign pays), the median of its wall
time, and the ratios free / pinned. The step's
CPU time, not its wall time, is what a loaded machine pays. Units: µs.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["METHODS", "main", "time_calls"]

METHODS = ("iterative-smooth", "large-projection", "classical")
"""The laws timed by default: the README's, the one that grows fastest with n, the plainest."""


def _burn(stop: Any) -> None:  # pragma: no cover - runs in the burner processes
    os.nice(19)
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x += 1


def time_calls(fn: Callable[[], Any], calls: int) -> tuple[np.ndarray, np.ndarray]:
    """CPU and wall time of each of ``calls`` calls of ``fn`` (µs)."""
    cpu, wall = np.empty(calls), np.empty(calls)
    for i in range(calls):
        c, w = time.process_time_ns(), time.perf_counter_ns()
        fn()
        cpu[i], wall[i] = time.process_time_ns() - c, time.perf_counter_ns() - w
    return cpu / 1e3, wall / 1e3


def _step(n: int, method: str) -> Callable[[], Any]:
    from redservo.bench.cases import scaling_case
    from redservo.bench.sensed import sensed_iteration
    from redservo.redundancy import make_law

    case = scaling_case(n)
    step = sensed_iteration(
        case.robot,
        case.scene,
        case.task,
        make_law(method),
        limits=case.limits,
        lam=case.lam,
        dt=case.dt,
    )
    return lambda: step(case.q)


def _measure(fn: Callable[[], Any], calls: int, rounds: int) -> dict[str, list[np.ndarray]]:
    from redservo.kernels.blas import one_blas_thread

    out: dict[str, list[np.ndarray]] = {"free": [], "pinned": []}
    for _ in range(rounds):
        cpu, wall = time_calls(fn, calls)
        out["free"] += [cpu, wall]
        with one_blas_thread():
            cpu, wall = time_calls(fn, calls)
        out["pinned"] += [cpu, wall]
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Print the measurements of the module docstring."""
    p = argparse.ArgumentParser(prog="python benchmarks/blas_threads.py", description=__doc__)
    p.add_argument("--n", type=int, default=100, help="joints")
    p.add_argument("--calls", type=int, default=200, help="calls per round")
    p.add_argument("--rounds", type=int, default=2, help="interleaved rounds")
    p.add_argument("--burners", type=int, default=os.cpu_count() or 1, help="burner processes")
    p.add_argument("--methods", nargs="+", default=list(METHODS))
    a = p.parse_args(argv)
    steps = {m: _step(a.n, m) for m in a.methods}
    for fn in steps.values():
        fn()  # compile or load the kernels before the load starts
    stop = multiprocessing.Event()
    burners = [multiprocessing.Process(target=_burn, args=(stop,)) for _ in range(a.burners)]
    for b in burners:
        b.start()
    try:
        time.sleep(0.5)
        load = " ".join(f"{x:.2f}" for x in os.getloadavg())
        res = {m: _measure(fn, a.calls, a.rounds) for m, fn in steps.items()}
    finally:
        stop.set()
        for b in burners:
            b.join()
    print(
        f"compiled step, n = {a.n}, {a.burners} burner process(es), {a.rounds} x {a.calls} "
        f"calls per case; load average {load} on {os.cpu_count()} CPUs"
    )
    for method, by_case in res.items():
        _report(method, by_case)
    return 0


def _report(method: str, by_case: dict[str, list[np.ndarray]]) -> None:
    print(f"{method}:")
    med, mean = {}, {}
    for name, arrays in by_case.items():
        cpu, wall = np.concatenate(arrays[0::2]), np.concatenate(arrays[1::2])
        med[name] = float(np.median(cpu))
        mean[name] = float(np.mean(cpu))
        print(
            f"  {name:7s} CPU median {med[name]:9.1f} µs  p90 {np.percentile(cpu, 90):9.1f} µs  "
            f"mean {mean[name]:9.1f} µs   wall median {np.median(wall):9.1f} µs"
        )
    print(
        f"  free / pinned: CPU median {med['free'] / med['pinned']:.1f}x, "
        f"CPU mean {mean['free'] / mean['pinned']:.1f}x"
    )


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
