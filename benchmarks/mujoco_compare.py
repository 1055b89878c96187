"""What the MuJoCo dynamics change (docs/physics.md): shipped scenarios, kinematic vs MuJoCo.

For each scenario and law, three runs: the kinematic simulator (``q ← q + q̇ dt``), MuJoCo
dynamics with the ideal sensor (``[simulator] kind = "mujoco"``), and MuJoCo dynamics seen
through MuJoCo's rendered camera (``camera = "rendered"``; scenarios whose targets MuJoCo
does not draw, or whose target MuJoCo's arm hides, say so). Printed per run: outcome,
iterations, the summary's minimum margin (fraction of the range, of the *simulated arm's*
joints), shield activations, the peak ``|q̇|/q̇_max`` the law commanded and the peak the arm
reached, and the peak joint-velocity tracking error ``|q̇ − q̇_cmd|`` (rad/s or m/s, over
every 1 ms physics step).

    .venv/bin/python benchmarks/mujoco_compare.py                       # the shipped set
    .venv/bin/python benchmarks/mujoco_compare.py --laws panda-mujoco-4points   # every law
    .venv/bin/python benchmarks/mujoco_compare.py --laws panda-4points \
        --modes kinematic,mujoco-ideal,mujoco-rendered-noarm   # the arm not drawn

Slow: a rendered run is ~0.1 s per iteration on a 2-core machine (it says what it runs).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np

from redservo import METHODS
from redservo.errors import RedservoError
from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario

SHIPPED = ("panda-4points", "panda-mujoco-4points", "afma6-gaze-demo", "cm01-gaze")
MODES: dict[str, list[str]] = {
    "kinematic": ['simulator.kind="kinematic"'],
    "mujoco-ideal": ['simulator.kind="mujoco"', 'simulator.camera="ideal"'],
    "mujoco-rendered": ['simulator.kind="mujoco"', 'simulator.camera="rendered"'],
    "mujoco-rendered-noarm": [
        'simulator.kind="mujoco"',
        'simulator.camera="rendered"',
        "simulator.draw_arm=false",
    ],
}


def run_one(name: str, mode: str, method: str | None) -> dict[str, Any]:
    """One run; a row of the table (or the reason it could not run)."""
    sc = apply_overrides(load_scenario(name), MODES[mode])
    t0 = time.perf_counter()
    try:
        exp = build(sc)
        res = exp.run(method=method)
    except RedservoError as exc:
        return {"scenario": name, "mode": mode, "method": method, "error": str(exc)[:140]}
    s = res.summary
    row: dict[str, Any] = {
        "scenario": name,
        "mode": mode,
        "method": method or sc.method,
        "outcome": res.outcome,
        "iterations": len(res.log),
        "min_margin": s.min_margin,
        "shield": s.shield_activations,
        "cmd_peak_ratio": s.peak_velocity_ratio,
        "seconds": time.perf_counter() - t0,
    }
    arm = getattr(exp.actuator, "arm", None)
    if arm is not None:
        qmax = exp.robot.qdot_max
        row["track_peak"] = float(arm.tracking.peak.max())
        row["track_rms"] = float(arm.tracking.rms.max())
        if qmax is not None:
            row["arm_peak_ratio"] = float(np.max(arm.tracking.peak_speed / qmax))
    return row


def fmt(row: dict[str, Any]) -> str:
    head = f"{row['scenario']:22s} {row['mode']:21s} {row['method']!s:20s}"
    if "error" in row:
        return f"{head} not run: {row['error']}"
    parts = [
        f"{row['outcome']:15s} it={row['iterations']:4d}",
        f"margin={row['min_margin']:.3f}",
        f"shield={row['shield']}",
        f"cmd|q̇|/max={row['cmd_peak_ratio']:.2f}" if row["cmd_peak_ratio"] is not None else "",
        f"arm|q̇|/max={row['arm_peak_ratio']:.2f}" if "arm_peak_ratio" in row else "",
        f"track_peak={row['track_peak']:.3f} rms={row['track_rms']:.4f}"
        if "track_peak" in row
        else "",
        f"({row['seconds']:.0f} s)",
    ]
    return f"{head} " + " ".join(p for p in parts if p)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--laws", metavar="SCENARIO", help="every law on this scenario instead")
    ap.add_argument("--modes", default="kinematic,mujoco-ideal,mujoco-rendered")
    args = ap.parse_args(argv)
    modes = args.modes.split(",")
    plan: list[tuple[str, str, str | None]] = []
    if args.laws:
        plan = [(args.laws, m, law) for law in METHODS for m in modes]
    else:
        plan = [(name, m, None) for name in SHIPPED for m in modes]
    for i, (name, mode, method) in enumerate(plan):
        print(f"[{i + 1}/{len(plan)}] {name} {mode} {method or ''}", file=sys.stderr, flush=True)
        print(fmt(run_one(name, mode, method)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
