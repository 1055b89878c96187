"""Benchmark: what compiling the kernels costs, cold and with the on-disk cache.

    .venv/bin/python benchmarks/compile_cost.py

Each figure comes from a fresh Python process. ``NUMBA_CACHE_DIR`` points at a new empty
directory, so the "cold" run compiles every kernel the run touches (without touching the
shared ``__pycache__`` of the source tree); the "warm" run repeats it with that cache
filled, which is what every later process pays. Measured: ``import redservo`` (no
kernel loaded), one call of every law through the public API, and one compiled step (the
campaign loop's iteration, :mod:`redservo.bench.sensed`).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile

_PROBE = """
import json, time
t0 = time.perf_counter()
import redservo
t1 = time.perf_counter()
import numpy as np
from redservo import METHODS, JointLimits, make_law
lim = JointLimits(-np.ones(7), np.ones(7), qdot_max=1.0, qddot_max=5.0)
J1 = np.random.default_rng(0).normal(size=(6, 7))
laws = {}
for m in METHODS:
    t = time.perf_counter()
    make_law(m)(J1=J1, e1=np.ones(6), q=np.zeros(7), limits=lim, lam=0.5, dt=0.04)
    laws[m] = time.perf_counter() - t
t2 = time.perf_counter()
from redservo.bench.cases import bench_cases
from redservo.bench.sensed import sensed_iteration
c = bench_cases(scaling=())[0]
s = sensed_iteration(c.robot, c.scene, c.task, make_law("classical"), limits=c.limits, lam=0.5, dt=0.04)
t3 = time.perf_counter()
s(c.q)
t4 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "laws": t2 - t1, "per_law": laws, "step": t4 - t3}))
"""


def probe(cache: str) -> dict[str, float]:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache}
    out = subprocess.run(
        [sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, check=True
    )
    data: dict[str, float] = json.loads(out.stdout.strip().splitlines()[-1])
    return data


def main() -> None:
    imports = []
    for _ in range(5):
        out = subprocess.run(
            [sys.executable, "-c", "import time; t = time.perf_counter(); import redservo; "
             "print(time.perf_counter() - t)"],
            capture_output=True, text=True, check=True,
        )  # fmt: skip
        imports.append(float(out.stdout))
    print(f"import redservo: median {statistics.median(imports):.3f} s over 5 processes")
    with tempfile.TemporaryDirectory(prefix="redservo-numba-") as cache:
        cold = probe(cache)
        warm = [probe(cache) for _ in range(3)]
    print(f"cold (empty cache): first call of the 12 laws {cold['laws']:.1f} s, "
          f"then the first compiled step {cold['step']:.1f} s")  # fmt: skip
    slowest = sorted(cold["per_law"].items(), key=lambda kv: -kv[1])[:3]
    print("  slowest first laws: " + ", ".join(f"{k} {v:.1f} s" for k, v in slowest))
    laws = statistics.median(w["laws"] for w in warm)
    step = statistics.median(w["step"] for w in warm)
    print(f"warm (cache filled): first call of the 12 laws {laws:.2f} s, "
          f"first compiled step {step:.2f} s (medians of 3 processes)")  # fmt: skip


if __name__ == "__main__":
    main()
