"""Control-step benchmarks (``redservo bench``): what users run, compiled and reference.

For each case of :mod:`redservo.bench.cases` and each method, up to four paths are timed:

* ``compiled``: the whole step (kinematics, ideal sensor, ``J1``, law, safety) as the
  campaign loop runs it at each iteration, two calls of the step kernel's drivers
  (:func:`redservo.bench.sensed.sensed_iteration`; ``qp`` with its compiled solver);
* ``api``: the same step through the public objects, ``robot.kinematics`` then
  ``task.evaluate`` then ``law(...)`` (what :func:`redservo.simulation.simulate` runs);
* ``law``: the law's public call alone, given ``J1`` and ``e1``;
* ``reference``: the ``compiled`` step with numba disabled (the same kernel source run as
  plain Python, in a subprocess with ``REDSERVO_NO_NUMBA=1``; main cases only).

Every (case, method, path) is timed in ``rounds`` interleaved rounds of ``batch`` calls
(each round visits every item once, so a change of machine load affects all items
alike); the tables report the median over rounds of the per-call time, in µs, and the
interquartile range. The moment features are also timed alone (``features``). The
harness prints progress through a callback and reports no targets: the speed
targets are checked by ``benchmarks/bench_control_step.py``.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from redservo.bench.cases import SCALING_N, BenchCase, bench_cases
from redservo.redundancy import METHODS, make_law

__all__ = ["BenchResult", "BenchRow", "bench_cases", "run_bench"]

Progress = Callable[[int, int, str], None]
MAIN_CASES = ("afma6-4points", "afma6-gaze", "afma6-moments", "panda-6d-free", "panda-6d-bounds")
_REFERENCE_CASES = ("afma6-4points", "afma6-gaze")


@dataclass(frozen=True)
class BenchRow:
    """One timed item: median and quartiles of the per-call time over the rounds (µs)."""

    case: str
    method: str
    path: str
    median_us: float
    q25_us: float
    q75_us: float
    rounds: int
    batch: int


@dataclass
class BenchResult:
    """All rows, the machine, and the throughput and first-call figures."""

    rows: list[BenchRow]
    machine: dict[str, Any] = field(default_factory=dict)
    throughput: dict[str, float] = field(default_factory=dict)
    first_call_s: dict[str, float] = field(default_factory=dict)

    def get(self, case: str, method: str, path: str) -> float | None:
        """The median (µs) of an item, or None if it was not timed."""
        for r in self.rows:
            if r.case == case and r.method == method and r.path == path:
                return r.median_us
        return None

    def to_json(self) -> dict[str, Any]:
        """A JSON-serialisable dict (``redservo bench --json``)."""
        return {
            "machine": self.machine,
            "rows": [asdict(r) for r in self.rows],
            "throughput_steps_per_s": self.throughput,
            "first_call_s": self.first_call_s,
        }

    @property
    def markdown(self) -> str:
        """The tables of the module docstring, as markdown."""
        m = self.machine
        out = [
            f"{m.get('cores')} core(s), load average {m.get('load_before')} before and "
            f"{m.get('load_after')} after; numba {m.get('numba') or 'absent (reference path)'}. "
            f"Medians over {m.get('rounds')} interleaved rounds of {m.get('batch')} calls, µs "
            "(interquartile range in brackets).",
            "",
            "| case | method | compiled step | API step | API law only | reference step | "
            "reference / compiled | API / compiled |",
            "|---|---|---:|---:|---:|---:|---:|---:|",
        ]
        cases = [c for c in dict.fromkeys(r.case for r in self.rows) if not c.startswith("dh-")]
        for case in cases:
            for method in dict.fromkeys(r.method for r in self.rows if r.case == case):
                cells = [
                    self._cell(case, method, p) for p in ("compiled", "api", "law", "reference")
                ]
                comp = self.get(case, method, "compiled")
                ref = self.get(case, method, "reference")
                api = self.get(case, method, "api")
                ratio = f"{ref / comp:.0f}x" if comp and ref else "—"
                api_ratio = f"{api / comp:.1f}x" if comp and api else "—"
                out.append(f"| {case} | {method} | {' | '.join(cells)} | {ratio} | {api_ratio} |")
        out += self._scaling_table()
        if self.throughput:
            out += ["", "Steps per second from Python (one process):", ""]
            out += [f"- {k}: {v:,.0f}" for k, v in self.throughput.items()]
        if self.first_call_s:
            out += ["", "First call in a fresh process (kernel cache warm), s:", ""]
            out += [f"- {k}: {v:.3g}" for k, v in self.first_call_s.items()]
        return "\n".join(out)

    def _cell(self, case: str, method: str, path: str) -> str:
        for r in self.rows:
            if r.case == case and r.method == method and r.path == path:
                return f"{r.median_us:.1f} [{r.q25_us:.1f}–{r.q75_us:.1f}]"
        return "—"

    def _scaling_table(self) -> list[str]:
        ns = sorted({int(r.case[3:]) for r in self.rows if r.case.startswith("dh-")})
        if not ns:
            return []
        methods = list(dict.fromkeys(r.method for r in self.rows if r.case.startswith("dh-")))
        out = [
            "",
            "Scaling with the number of joints n (m = 6), compiled step / API law only, µs:",
            "",
            "| method | " + " | ".join(f"n = {n}" for n in ns) + " |",
            "|---|" + "---:|" * len(ns),
        ]
        for method in methods:
            cells = []
            for n in ns:
                c = self.get(f"dh-{n}", method, "compiled")
                law = self.get(f"dh-{n}", method, "law")
                cells.append(f"{c:.1f} / {law:.1f}" if c and law else "—")
            out.append(f"| {method} | " + " | ".join(cells) + " |")
        return out


def _law_kwargs(case: BenchCase) -> dict[str, Any]:
    bMc, J = case.robot.kinematics(case.q, check_limits=False)
    st = case.task.evaluate(case.scene, bMc, J, 0.0)
    return {"J1": st.J1, "e1": st.e1, "q": case.q, "limits": case.limits}


def _items(
    case: BenchCase, method: str, paths: Sequence[str]
) -> list[tuple[str, Callable[[], Any]]]:
    """The callables to time for (case, method) on ``paths``."""
    from redservo.bench.sensed import sensed_iteration

    law = make_law(method)
    kw = {**_law_kwargs(case), "lam": case.lam, "dt": case.dt}
    robot, task, scene, q = case.robot, case.task, case.scene, case.q
    out: list[tuple[str, Callable[[], Any]]] = []
    if "compiled" in paths and method != "predictive":  # predictive: a Python step only
        step = sensed_iteration(
            robot, scene, task, law, limits=case.limits, lam=case.lam, dt=case.dt
        )
        out.append(("compiled", lambda: step(q)))
    if "api" in paths:

        def api() -> Any:
            bMc, J = robot.kinematics(q)
            st = task.evaluate(scene, bMc, J, 0.0)
            observe = getattr(law, "observe", None)  # predictive: its global model
            if observe is not None:
                observe(robot, task, st)
            return law(J1=st.J1, e1=st.e1, q=q, limits=case.limits, lam=case.lam, dt=case.dt)

        out.append(("api", api))
    if "law" in paths:
        out.append(("law", lambda: law(**kw)))
    return out


def _time_batch(fn: Callable[[], Any], batch: int) -> float:
    clock = time.perf_counter_ns
    t0 = clock()
    for _ in range(batch):
        fn()
    return (clock() - t0) / batch / 1e3


def _measure(
    items: list[tuple[str, str, str, Callable[[], Any]]],
    rounds: int,
    batch: int,
    progress: Progress | None,
) -> list[BenchRow]:
    for *_, fn in items:  # warm-up: compile or load every kernel before timing
        for _ in range(3):
            fn()
    times = np.empty((rounds, len(items)))
    total = rounds * len(items)
    for r in range(rounds):
        for i, (case, method, path, fn) in enumerate(items):
            times[r, i] = _time_batch(fn, batch)
            if progress is not None:
                progress(r * len(items) + i + 1, total, f"{case} {method} {path}")
    rows = []
    for i, (case, method, path, _) in enumerate(items):
        q25, med, q75 = np.percentile(times[:, i], [25, 50, 75])
        rows.append(BenchRow(case, method, path, float(med), float(q25), float(q75), rounds, batch))
    return rows


def _moment_features_items(case: BenchCase) -> list[tuple[str, str, str, Callable[[], Any]]]:
    from redservo.kernels import moment_interaction as ki
    from redservo.kernels import moments as km

    feat = case.task.terms[0].feature
    bMc = case.robot.fkine(case.q)
    cMo = np.ascontiguousarray(case.scene.cMo("t", bMc, 0.0))
    pts = np.ascontiguousarray(feat.points_o)  # type: ignore[attr-defined]
    a, z = feat.desired_area, feat.desired_depth  # type: ignore[attr-defined]
    kind = ("c4c6", "pxpy", "sxsy").index(feat.rotation_features)  # type: ignore[attr-defined]

    def compiled() -> Any:
        _, plane, xg, yg, mu, _, _ = km.moment_measure(pts, cMo, a, z, kind)
        return ki.moment_features_interaction(pts.shape[0], xg, yg, mu, plane, a, z, kind)

    def api() -> Any:
        m = feat.measure(cMo)
        return feat.interaction(m.s, m.inv_depth)

    return [(case.name, "-", "compiled", compiled), (case.name, "-", "api", api)]


def _reference(cases: list[str], methods: list[str], rounds: int, batch: int) -> list[BenchRow]:
    """Time the compiled step with numba disabled, in a subprocess."""
    code = (
        "import json, sys; from redservo.bench.steps import _reference_main; "
        "print(json.dumps(_reference_main(*json.loads(sys.argv[1]))))"
    )
    env = {**os.environ, "REDSERVO_NO_NUMBA": "1"}
    arg = json.dumps([cases, methods, rounds, batch])
    done = subprocess.run(
        [sys.executable, "-c", code, arg], env=env, capture_output=True, text=True, check=True
    )
    return [BenchRow(**r) for r in json.loads(done.stdout.strip().splitlines()[-1])]


def _reference_main(cases: list[str], methods: list[str], rounds: int, batch: int) -> list[Any]:
    """Entry point of the reference subprocess (numba disabled by the environment)."""
    by_name = {c.name: c for c in bench_cases(scaling=())}
    items = [
        (name, m, "reference", fn)
        for name in cases
        for m in methods
        if m not in ("qp", "predictive")
        for _, fn in _items(by_name[name], m, ("compiled",))
    ]
    return [asdict(r) for r in _measure(items, rounds, batch, None)]


def _first_call() -> dict[str, float]:
    """``import redservo`` and the first compiled step in a fresh process (cache warm)."""
    code = (
        "import time; t0 = time.perf_counter(); import redservo; t1 = time.perf_counter()\n"
        "from redservo.bench.cases import bench_cases; from redservo.redundancy import make_law\n"
        "from redservo.bench.sensed import sensed_iteration\n"
        "c = bench_cases(scaling=())[0]\n"
        "s = sensed_iteration(c.robot, c.scene, c.task, make_law('iterative-smooth'), "
        "limits=c.limits, lam=c.lam, dt=c.dt)\n"
        "t2 = time.perf_counter(); s(c.q); t3 = time.perf_counter()\n"
        "print(t1 - t0, t3 - t2)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    imp, first = (float(v) for v in out.stdout.split())
    return {"import redservo": imp, "first compiled step (numba import + cache load)": first}


def _throughput(case: BenchCase, steps: int) -> dict[str, float]:
    from redservo.bench.sensed import sensed_iteration
    from redservo.simulation import SimulationOptions, simulate

    opt = SimulationOptions(
        lam=case.lam, dt=case.dt, max_iterations=steps, stop_at_convergence=False, check_image=False
    )
    out: dict[str, float] = {}
    for name in ("classical", "iterative-smooth"):
        t0 = time.perf_counter()
        res = simulate(case.robot, case.scene, case.task, make_law(name), case.q, options=opt)
        out[f"simulate(), {case.name}, {name}"] = len(res.log) / (time.perf_counter() - t0)
        step = sensed_iteration(
            case.robot,
            case.scene,
            case.task,
            make_law(name),
            limits=case.limits,
            lam=case.lam,
            dt=case.dt,
        )
        q, prev = case.q.copy(), np.zeros(case.robot.n)
        step(q, prev)  # warm-up: load the kernel before timing
        t0 = time.perf_counter()
        for _ in range(steps):  # closed loop: the command moves the robot
            prev = step(q, prev).copy()
            q = q + case.dt * prev
        out[f"compiled step loop, {case.name}, {name}"] = steps / (time.perf_counter() - t0)
    return out


def run_bench(
    *,
    repeat: int = 1000,
    rounds: int = 10,
    methods: Sequence[str] | None = None,
    cases: Sequence[str] | None = None,
    scaling: Sequence[int] = SCALING_N,
    reference: bool = True,
    throughput_steps: int = 200,
    first_call: bool = True,
    progress: Progress | None = None,
) -> BenchResult:
    """Time every (case, method, path); see the module docstring.

    Args:
        repeat: Timed calls per item in total (``rounds`` batches of ``repeat // rounds``).
        rounds: Interleaved rounds; the reported figure is the median over them.
        methods: Methods to time (default :data:`redservo.METHODS`).
        cases: Main cases to time (default all of :data:`MAIN_CASES`).
        scaling: Joint counts of the scaling cases (``()`` to skip them).
        reference: Also time the reference (numba disabled) path in a subprocess.
        throughput_steps: Steps of the throughput runs (0 to skip).
        first_call: Time ``import redservo`` and the first compiled step in a fresh process.
        progress: ``progress(done, total, label)`` after each timed batch.
    """
    from redservo.kernels import compiled
    from redservo.kernels._jit import numba_version

    names = list(methods or METHODS)
    wanted = list(cases) if cases is not None else list(MAIN_CASES)
    batch = max(1, repeat // rounds)
    load0 = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    all_cases = bench_cases(scaling=tuple(scaling))
    items: list[tuple[str, str, str, Callable[[], Any]]] = []
    for case in all_cases:
        scal = case.name.startswith("dh-")
        if not scal and case.name not in wanted:
            continue
        paths = ("compiled", "law") if scal else ("compiled", "api", "law")
        for m in names:
            items += [(case.name, m, p, fn) for p, fn in _items(case, m, paths)]
        if case.name == "afma6-moments":
            items += _moment_features_items(case)
    rows = _measure(items, rounds, batch, progress)
    ref_cases = [c for c in _REFERENCE_CASES if c in wanted]
    if reference and ref_cases and compiled():
        rows += _reference(ref_cases, names, max(3, rounds // 3), max(1, batch // 50))
    machine = {
        "cores": os.cpu_count(),
        "load_before": round(load0, 2),
        "load_after": round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None,
        "numba": numba_version(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "rounds": rounds,
        "batch": batch,
    }
    main = next((c for c in all_cases if c.name == "afma6-4points"), None)
    result = BenchResult(rows, machine)
    if throughput_steps > 0 and main is not None and compiled():
        result.throughput = _throughput(main, throughput_steps)
    if first_call and compiled():
        result.first_call_s = _first_call()
    return result
