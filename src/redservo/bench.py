"""Control-step timing (``redservo bench``) and campaign throughput.

For each case and each method it measures, over ``repeat`` timed calls:

1. **law**: the law alone, given ``J1`` and ``e1`` (what a real controller pays);
2. **full**: a whole control step: forward kinematics, Jacobian, feature
   measurement, interaction matrix, ``J1`` and the law.

Times are reported as the median and 95th percentile in µs, and as a ratio to
the median time of one ``numpy.linalg.svd`` of a 6x6 matrix measured in the same
run ("SVD units"), so figures from different machines can be compared. The
target (issue 5) is a full step of ``iterative-smooth`` on the Afma6 gazing task
≤ 60 µs median and ≤ 7 SVD units on a 2-core CI-class machine.

Cases (self-contained, no scenario file needed): the Afma6 gazing task (m = 2,
n = 6) from near the limits; the Afma6 four-point moment task (m = 6, n = 6);
the humanoid torso gazing at a point (m = 2, n = 9).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from redservo.features import MomentFeatures, PointFeature
from redservo.limits import JointLimits
from redservo.redundancy import METHODS, make_law
from redservo.robots import Afma6, Humanoid9, Robot
from redservo.scene import PointSet, Scene, Static
from redservo.simulation import SimulationOptions, simulate
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

__all__ = ["BenchResult", "BenchRow", "bench_cases", "run_bench", "svd_reference"]

TARGET_US = 60.0
TARGET_SVD_UNITS = 7.0


@dataclass(frozen=True)
class BenchCase:
    """A robot, a scene, a task and a configuration to time the control step at."""

    name: str
    robot: Robot
    scene: Scene
    task: VisualTask
    q: np.ndarray
    limits: JointLimits
    lam: float = 0.5
    dt: float = 0.04


def bench_cases() -> list[BenchCase]:
    """The three benchmark cases of issue 5."""
    afma = Afma6()
    q_g = np.array([-0.5967, -0.165, 0.4119, 1.2829, 0.3967, -0.6108])  # near the limits
    gaze_scene = Scene(
        [
            PointSet(
                "t",
                np.zeros((1, 3)),
                trajectory=Static(afma.fkine(q_g) @ make_transform(t=(-0.368, 0.017, 0.876))),
            )
        ]
    )
    gaze = VisualTask([TaskTerm(PointFeature(), "t")], [0.0, 0.0])

    q_m = afma.limits().center + np.array([0.2, -0.1, 0.1, 0.3, 0.2, -0.2])
    pts = np.array([[-0.05, -0.04, 0.0], [0.07, -0.05, 0.0], [0.04, 0.06, 0.0], [-0.06, 0.03, 0.0]])
    mom_scene = Scene(
        [
            PointSet(
                "t",
                pts,
                trajectory=Static(
                    afma.fkine(q_m) @ make_transform(t=(0.05, -0.03, 0.7), rotvec=(0.1, -0.1, 0.2))
                ),
            )
        ]
    )
    desired = make_transform(t=(0.0, 0.0, 0.5))
    mom = VisualTask.from_desired_poses(
        [TaskTerm(MomentFeatures.at_desired_pose(pts, desired), "t")], {"t": desired}
    )

    hum = Humanoid9()
    q_h = hum.rest_configuration()
    hum_scene = Scene(
        [
            PointSet(
                "t",
                np.zeros((1, 3)),
                trajectory=Static(hum.fkine(q_h) @ make_transform(t=(0.3, 0.1, 2.0))),
            )
        ]
    )
    hum_task = VisualTask([TaskTerm(PointFeature(), "t")], [0.0, 0.0])
    return [
        BenchCase("afma6-gaze (m=2, n=6)", afma, gaze_scene, gaze, q_g, afma.limits()),
        BenchCase("afma6-moments (m=6, n=6)", afma, mom_scene, mom, q_m, afma.limits()),
        BenchCase("humanoid-gaze (m=2, n=9)", hum, hum_scene, hum_task, q_h, hum.limits()),
    ]


def _time_calls(fn: Callable[[], Any], repeat: int) -> np.ndarray:
    """Per-call times in µs (after a warm-up)."""
    for _ in range(min(50, repeat)):
        fn()
    out = np.empty(repeat)
    clock = time.perf_counter_ns
    for i in range(repeat):
        t0 = clock()
        fn()
        out[i] = clock() - t0
    return out / 1e3


def svd_reference(repeat: int = 2000) -> float:
    """Median time (µs) of one ``numpy.linalg.svd`` of a 6x6 matrix."""
    A = np.random.default_rng(0).normal(size=(6, 6))
    return float(np.median(_time_calls(lambda: np.linalg.svd(A), repeat)))


@dataclass(frozen=True)
class BenchRow:
    """Timing of one method on one case (µs and SVD units)."""

    case: str
    method: str
    law_median: float
    law_p95: float
    full_median: float
    full_p95: float
    svd_us: float

    @property
    def full_units(self) -> float:
        return self.full_median / self.svd_us

    @property
    def law_units(self) -> float:
        return self.law_median / self.svd_us


@dataclass
class BenchResult:
    """All rows, the SVD reference and the campaign throughput."""

    rows: list[BenchRow]
    svd_us: float
    throughput: dict[str, float] = field(default_factory=dict)
    cores: int = 1

    def target_row(self) -> BenchRow | None:
        """The row the issue-5 target is about (iterative-smooth, Afma6 gazing)."""
        for r in self.rows:
            if r.method == "iterative-smooth" and r.case.startswith("afma6-gaze"):
                return r
        return None

    @property
    def markdown(self) -> str:
        lines = [
            f"One numpy.linalg.svd of a 6x6 matrix: {self.svd_us:.1f} µs (the SVD unit). "
            f"{self.cores} core(s).",
            "",
            "| case | method | law median (µs) | law p95 (µs) | law (SVD u.) | "
            "full step median (µs) | full p95 (µs) | full (SVD u.) |",
            "|---|---|---:|---:|---:|---:|---:|---:|",
        ]
        for r in self.rows:
            lines.append(
                f"| {r.case} | {r.method} | {r.law_median:.1f} | {r.law_p95:.1f} | "
                f"{r.law_units:.2f} | {r.full_median:.1f} | {r.full_p95:.1f} | {r.full_units:.2f} |"
            )
        t = self.target_row()
        if t is not None:
            ok_us = "meets" if t.full_median <= TARGET_US else "misses"
            ok_u = "meets" if t.full_units <= TARGET_SVD_UNITS else "misses"
            lines += [
                "",
                f"Target (iterative-smooth, Afma6 gazing, full step): {t.full_median:.1f} µs median "
                f"({ok_us} ≤ {TARGET_US:.0f} µs), {t.full_units:.2f} SVD units "
                f"({ok_u} ≤ {TARGET_SVD_UNITS:.0f}).",
            ]
        if self.throughput:
            lines += ["", "Simulation throughput (one process, control steps per second):", ""]
            lines += [f"- {m}: {v:,.0f} steps/s" for m, v in self.throughput.items()]
            lines.append(
                f"- a campaign on {self.cores} worker(s) runs about {self.cores}x this rate"
            )
        return "\n".join(lines)


def _full_step(case: BenchCase, law: Any) -> Callable[[], Any]:
    robot, scene, task, q, lim = case.robot, case.scene, case.task, case.q, case.limits
    lam, dt = case.lam, case.dt

    def step() -> Any:
        bMc, J = robot.kinematics(q)
        st = task.evaluate(scene, bMc, J, 0.0)
        return law(J1=st.J1, e1=st.e1, q=q, limits=lim, lam=lam, dt=dt)

    return step


def run_bench(
    *,
    repeat: int = 2000,
    methods: tuple[str, ...] | None = None,
    cases: list[BenchCase] | None = None,
    throughput_steps: int = 300,
) -> BenchResult:
    """Time every method on every case; see the module docstring.

    Args:
        repeat: Timed calls per (case, method) and per measurement.
        methods: Methods to time (default: all of :data:`redservo.METHODS`).
        cases: Cases (default :func:`bench_cases`).
        throughput_steps: Iterations of the throughput simulation (0 to skip).
    """
    names = methods or METHODS
    rows: list[BenchRow] = []
    svd_us = svd_reference(repeat)
    for case in cases or bench_cases():
        st = case.task.evaluate(case.scene, case.robot.fkine(case.q), case.robot.jacobian(case.q))
        for name in names:
            law = make_law(name)

            def law_only(law: Any = law, st: Any = st, case: BenchCase = case) -> Any:
                return law(
                    J1=st.J1, e1=st.e1, q=case.q, limits=case.limits, lam=case.lam, dt=case.dt
                )

            t_law = _time_calls(law_only, repeat)
            t_full = _time_calls(_full_step(case, law), repeat)
            rows.append(
                BenchRow(
                    case.name,
                    name,
                    float(np.median(t_law)),
                    float(np.percentile(t_law, 95)),
                    float(np.median(t_full)),
                    float(np.percentile(t_full, 95)),
                    svd_us,
                )
            )
    throughput: dict[str, float] = {}
    if throughput_steps > 0:
        case = (cases or bench_cases())[0]
        opt = SimulationOptions(
            lam=case.lam,
            dt=case.dt,
            max_iterations=throughput_steps,
            stop_at_convergence=False,
            check_image=False,
        )
        for name in ("classical", "iterative-smooth", "directional"):
            if name not in names:
                continue
            t0 = time.perf_counter()
            res = simulate(case.robot, case.scene, case.task, make_law(name), case.q, options=opt)
            throughput[name] = len(res.log) / (time.perf_counter() - t0)
    return BenchResult(rows, svd_us, throughput, os.cpu_count() or 1)
