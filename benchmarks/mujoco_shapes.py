"""Spheres, cylinders and lines through MuJoCo's camera (docs/physics.md, "Spheres, cylinders
and lines"): how far the measured ellipse, limbs and line are from our projection model on
static scenes at random poses (and carried by the arm, eye-to-hand), and the CM01 sphere and
cylinder scenarios run to the end through the rendered camera against the kinematic simulator.

    .venv/bin/python benchmarks/mujoco_shapes.py [--samples 20] [--noise 2] [--no-runs]

Prints, over the poses measured: the sphere's centre and semi-axes errors (px), the limbs'
and the line's ρ (px) and θ (rad) errors (max and median), then per scenario the outcome,
iterations and wall time with each simulator.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from dataclasses import replace

import numpy as np

from redservo.camera import Camera
from redservo.experiment.build import build
from redservo.features import CylinderFeature, LineFeature, SphereFeature
from redservo.features.base import wrap_angle
from redservo.physics import MujocoArm, MujocoCamera
from redservo.robots import Panda
from redservo.scenario import load_scenario, parse_scenario
from redservo.scene import Cylinder, Line, Scene, Sphere, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask


def _axes(s: np.ndarray, px: float) -> np.ndarray:
    """Semi-axes (px) of the ellipse of ``(xc, yc, n20, n11, n02)``."""
    n20, n11, n02 = s[2:]
    return np.sqrt(4.0 * np.linalg.eigvalsh([[n20, n11], [n11, n02]])) * px


def agreement(samples: int, noise: float, camera: Camera) -> None:
    """Print the static agreement of the sphere's and the cylinder's features."""
    robot = Panda()
    q = robot.ready_configuration()
    bMc = robot.fkine(q)
    rng = np.random.default_rng(0)
    sph, cyl, lin, lost = [], [], [], 0
    for _ in range(samples):
        cMo = make_transform(
            t=(rng.uniform(-0.08, 0.08), rng.uniform(-0.06, 0.06), rng.uniform(0.4, 0.8)),
            rotvec=rng.uniform(-0.6, 0.6, 3),
        )
        r = float(rng.uniform(0.03, 0.07))
        y = np.array([0.0, 1.0, 0.0])
        for obj, feature in (
            (Sphere("o", radius=r), SphereFeature(r, variant="moments")),
            (Cylinder("o", radius=0.5 * r, axis=y), CylinderFeature(0.5 * r, y)),
            (Line("o", point=np.zeros(3), direction=y), LineFeature(np.zeros(3), y)),
        ):
            scene = Scene([replace(obj, trajectory=Static(bMc @ cMo))])
            arm = MujocoArm(robot, scene, camera=camera, q_ref=q)
            task = VisualTask([TaskTerm(feature, "o")], s_star=feature.measure(cMo).s)
            reading = MujocoCamera(arm, depth="true", noise_px=noise).read(task, scene, bMc, 0.0)
            arm.close()
            truth = feature.measure(cMo).s
            if reading.s is None or reading.lost:
                lost += 1
                print(f"  not measured: {reading.reason}")
                continue
            d = reading.s - truth
            if isinstance(feature, SphereFeature):
                axes = np.abs(_axes(reading.s, camera.px) - _axes(truth, camera.px))
                sph.append(np.r_[np.abs(d[:2]) * camera.px, axes])
            elif isinstance(feature, CylinderFeature):
                cyl.append(np.r_[np.abs(d[[0, 2]]) * camera.px, np.abs(wrap_angle(d[[1, 3]]))])
            else:
                lin.append(np.r_[abs(d[0]) * camera.px, abs(wrap_angle(d[1]))])
    s, c, ln = np.array(sph), np.array(cyl), np.array(lin)
    size = f"{camera.width}x{camera.height}, noise {noise:g}"
    print(
        f"sphere   {size}: {len(s)} poses, centre max {s[:, :2].max():.3f} px "
        f"(median {np.median(s[:, :2]):.3f}), semi-axes max {s[:, 2:].max():.3f} px "
        f"(median {np.median(s[:, 2:]):.3f})"
    )
    print(
        f"cylinder {size}: {len(c)} poses, rho max {c[:, :2].max():.3f} px "
        f"(median {np.median(c[:, :2]):.3f}), theta max {c[:, 2:].max():.1e} rad "
        f"(median {np.median(c[:, 2:]):.1e})"
    )
    print(
        f"line     {size}: {len(ln)} poses, rho max {ln[:, 0].max():.3f} px "
        f"(median {np.median(ln[:, 0]):.3f}), theta max {ln[:, 1].max():.1e} rad "
        f"(median {np.median(ln[:, 1]):.1e}); {lost} measurement(s) failed"
    )


def eye_to_hand(samples: int, noise: float, camera: Camera) -> None:
    """Print the agreement of a sphere and a cylinder carried 16 cm off the Panda's flange,
    seen by the fixed camera of ``benchmarks/mujoco_world_camera.py`` (arm behind them)."""
    from redservo.robots.eye_to_hand import EyeToHandRobot

    q0 = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    robot = EyeToHandRobot(
        Panda(), make_transform(t=(0.95, 0.0, 0.55), rotvec=(-1.2092,) * 2 + (1.2092,))
    )
    eMo = Static(make_transform(t=(0.0, 0.0, 0.16)))
    for obj, feature in (
        (Sphere("o", radius=0.04, trajectory=eMo), SphereFeature(0.04, variant="moments")),
        (
            Cylinder("o", radius=0.02, axis=np.array([1.0, 0.0, 0.0]), trajectory=eMo),
            CylinderFeature(0.02, (1.0, 0.0, 0.0)),
        ),
    ):
        scene = Scene([obj])
        arm = MujocoArm(robot, scene, camera=camera, q_ref=q0)
        task = VisualTask(
            [TaskTerm(feature, "o")], s_star=feature.measure(make_transform(t=(0.0, 0.0, 1.0))).s
        )
        cam = MujocoCamera(arm, depth="true", noise_px=noise)
        rng = np.random.default_rng(1)
        err = []
        for _ in range(samples):
            q = np.clip(q0 + rng.uniform(-0.15, 0.15, 7), robot.q_min, robot.q_max)
            arm.set_q(q)
            cam.reset()
            reading = cam.read(task, scene, robot.fkine(q), 0.0)
            truth, _ = task.measure(scene, robot.fkine(q), 0.0)
            if reading.s is None or reading.lost:
                print(f"  not measured: {reading.reason}")
                continue
            d = reading.s - truth
            err.append(np.abs(d[:2] if isinstance(feature, SphereFeature) else d[[0, 2]]))
        arm.close()
        what = "sphere centre" if isinstance(feature, SphereFeature) else "limbs' rho"
        e = np.array(err) * camera.px
        print(
            f"eye-to-hand {what}: {len(e)}/{samples} postures, max {e.max():.3f} px, "
            f"median {np.median(e):.3f} px"
        )


def runs() -> None:
    """Print the CM01 sphere and cylinder scenarios, kinematic vs MuJoCo images."""
    for name in ("cm01-humanoid-sphere", "cm01-cylinder"):
        for kind in ("kinematic", "mujoco images"):
            data = copy.deepcopy(load_scenario(name).data)
            if kind != "kinematic":
                data["simulator"] = {"kind": "mujoco", "camera": "rendered"}
            t0 = time.perf_counter()
            res = build(parse_scenario(data, f"{name}.toml")).run()
            e = float(np.linalg.norm(res.log.e1[-1]))
            print(
                f"{name:21s} {kind:13s}: {res.outcome}, {len(res.log)} iterations, "
                f"final |e| {e:.1e}, {time.perf_counter() - t0:.1f} s",
                flush=True,
            )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20)
    ap.add_argument("--noise", type=float, default=2.0, help="gray levels")
    ap.add_argument("--width", type=int, default=640, help="image width (height 3/4 of it)")
    ap.add_argument("--no-runs", action="store_true", help="only the static agreement")
    args = ap.parse_args(argv)
    w = args.width
    camera = Camera(
        px=0.9375 * w, py=0.9375 * w, u0=w / 2, v0=3 * w / 8, width=w, height=3 * w // 4
    )
    print(f"rendering {3 * args.samples} static frames ...", file=sys.stderr, flush=True)
    agreement(args.samples, args.noise, camera)
    eye_to_hand(max(args.samples // 2, 1), args.noise, camera)
    if not args.no_runs:
        print("running 4 scenarios to the end (about a minute) ...", file=sys.stderr, flush=True)
        runs()
    return 0


if __name__ == "__main__":
    sys.exit(main())
