"""MuJoCo backend speed per 640x480 frame: physics step, render, detect (docs/physics.md).

Wall time and CPU time (all threads of the process, Mesa's llvmpipe included): on a machine
shared with other jobs the wall time grows with the load, the CPU time much less.

The shipped ``panda-mujoco-4points`` scenario, the arm moving under a constant command: per
control period (40 ms) the physics advances 40 steps of 1 ms, then the camera renders
(MuJoCo, EGL, shadows) and the image sensor detects and tracks the dots. Target (issue 23):
physics + render + detect <= 60 ms per frame. Medians over ``--frames`` frames.

    .venv/bin/python benchmarks/bench_mujoco.py [--frames 60]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--no-shadows", action="store_true")
    ap.add_argument("--offsamples", type=int, default=None, help="MSAA samples (MuJoCo: 4)")
    args = ap.parse_args(argv)
    from redservo.experiment.build import build
    from redservo.physics.camera import MujocoCamera
    from redservo.scenario import apply_overrides, load_scenario

    sets = [] if not args.no_shadows else ["simulator.shadows=false"]
    exp = build(apply_overrides(load_scenario("panda-mujoco-4points"), sets))
    cam = exp.sensor
    assert isinstance(cam, MujocoCamera)
    arm = cam.arm
    if args.offsamples is not None:
        arm.model.vis.quality.offsamples = args.offsamples
    arm.set_q(exp.q0)
    cam.reset()
    cam._plan(exp.task, exp.scene)  # the dot tracker of the task (what read() does first)
    cmd = np.zeros(exp.robot.n)
    cmd[6] = 0.05  # rad/s: the image turns slowly, the dots stay in view
    dt = exp.options.dt
    wall: dict[str, list[float]] = {"physics": [], "render": [], "detect": []}
    cpu: dict[str, list[float]] = {"physics": [], "render": [], "detect": []}
    print(
        f"MUJOCO_GL={os.environ.get('MUJOCO_GL')}, {exp.camera.width}x{exp.camera.height}, "
        f"{args.frames} frames...",
        file=sys.stderr,
    )
    clocks = (time.perf_counter, time.process_time)
    for k in range(args.frames):
        t0 = [c() for c in clocks]
        arm.step(cmd, dt)
        t1 = [c() for c in clocks]
        bMc = exp.robot.fkine(arm.q, check_limits=False)
        image = cam.renderer.render(exp.scene, bMc, k * dt)
        t2 = [c() for c in clocks]
        cam._read_dots(image, exp.scene, bMc, k * dt, k == 0, [])
        t3 = [c() for c in clocks]
        if k == 0:
            continue  # the first frame starts the tracker and the renderer's context
        for i, out in enumerate((wall, cpu)):
            out["physics"].append(t1[i] - t0[i])
            out["render"].append(t2[i] - t1[i])
            out["detect"].append(t3[i] - t2[i])
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    for label, data in (("wall", wall), ("CPU (all threads)", cpu)):
        ms = {name: 1e3 * statistics.median(v) for name, v in data.items()}
        total = sum(ms.values())
        print(
            f"{label} per frame (median of {len(data['render'])}): physics "
            f"{ms['physics']:.1f} ms ({round(dt / arm.timestep)} steps of "
            f"{arm.timestep * 1e3:g} ms), render {ms['render']:.1f} ms, detect "
            f"{ms['detect']:.1f} ms; total {total:.1f} ms "
            f"(target 60 ms: {'met' if total <= 60.0 else 'missed'})"
        )
    print(f"load average {load:.1f} on {os.cpu_count()} cores (wall time grows with it)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
