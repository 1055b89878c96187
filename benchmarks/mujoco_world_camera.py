"""Eye-to-hand through MuJoCo (docs/physics.md, "Eye-to-hand"): how far the features measured
in the fixed camera's rendered image are from our projection model, at random postures near
the start of ``panda-mujoco-eye-to-hand``, for its dots card and for an AprilTag card, with a
pinhole lens or (``--lens``) the scenario's distorted one (errors in undistorted pixels).

    .venv/bin/python benchmarks/mujoco_world_camera.py [--samples 10] [--width 640] [--lens]

Prints, per target, the largest and the median error over the features and postures (px),
and the carried object's pose against our kinematics ``bMe(q) · eMo`` (m / rad).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from redservo.camera import Camera
from redservo.features import PointFeature
from redservo.physics import MujocoArm, MujocoCamera
from redservo.robots import Panda
from redservo.robots.eye_to_hand import EyeToHandRobot
from redservo.scene import PointSet, Scene, Static, Tag
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

Q0 = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
WMC = make_transform(t=(0.95, 0.0, 0.55), rotvec=(-1.2092, -1.2092, 1.2092))
EMO_DOTS = make_transform(t=(0.0, -0.06, 0.01), rotvec=(0.331, -2.031, -1.553))
EMO_TAG = make_transform(t=(0.0, -0.06, 0.05), rotvec=(-1.075, 1.6977, -1.593))
LENS = (-0.12, 0.05, 0.0005, -0.0004, 0.0)  # the scenario's k1, k2, p1, p2, k3
SQUARE = np.array([[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0]])


def measure(scene: Scene, name: str, camera: Camera, samples: int, spread: float) -> None:
    """Print the projection error (px) and the carried pose error of one target."""
    robot = EyeToHandRobot(Panda(), WMC)
    arm = MujocoArm(robot, scene, camera=camera, q_ref=Q0)
    obj = scene.object(name)
    task = VisualTask(
        [TaskTerm(PointFeature(p), name) for p in obj.points], s_star=np.zeros(2 * len(obj.points))
    )
    cam = MujocoCamera(arm, depth="true")
    rng = np.random.default_rng(0)
    errs, pose = [], 0.0
    for _ in range(samples):
        q = np.clip(Q0 + rng.uniform(-spread, spread, 7), robot.q_min, robot.q_max)
        arm.set_q(q)
        bMc = robot.fkine(q)
        cam.reset()
        reading = cam.read(task, scene, bMc, 0.0)
        if reading.s is None or reading.lost:
            print(f"  {name}: not measured at q = {np.round(q, 3)}: {reading.reason}")
            continue
        truth, _ = task.measure(scene, bMc, 0.0)
        errs.append(np.abs((reading.s - truth).reshape(-1, 2)) * [camera.px, camera.py])
        bMo = robot.carrier.fkine_ee(q) @ scene.wMo(name, 0.0)
        pose = max(pose, float(np.abs(arm.object_pose(name) - bMo).max()))
    e = np.concatenate(errs) if errs else np.zeros((0, 2))
    print(
        f"{name:7s} {camera.width}x{camera.height}: {len(errs)}/{samples} postures measured, "
        f"feature error max {e.max():.3f} px, median {np.median(e):.3f} px; "
        f"carried pose vs bMe(q) eMo: {pose:.1e}"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10)
    ap.add_argument("--width", type=int, default=640, help="image width (height 3/4 of it)")
    ap.add_argument("--spread", type=float, default=0.15, help="rad around the start")
    ap.add_argument("--lens", action="store_true", help="the scenario's distorted lens")
    args = ap.parse_args(argv)
    w = args.width
    k = dict(zip(("k1", "k2", "p1", "p2", "k3"), LENS, strict=True)) if args.lens else {}
    camera = Camera(0.9375 * w, 0.9375 * w, w / 2, 3 * w / 8, w, 3 * w // 4, **k)
    print(f"rendering {2 * args.samples} frames ...", file=sys.stderr, flush=True)
    measure(
        Scene([PointSet("dots", SQUARE, trajectory=Static(EMO_DOTS))]),
        "dots",
        camera,
        args.samples,
        args.spread,
    )
    tag = Tag("tag", size=0.1, tag_id=7, trajectory=Static(EMO_TAG))
    measure(Scene([tag]), "tag", camera, args.samples, args.spread)
    return 0


if __name__ == "__main__":
    sys.exit(main())
