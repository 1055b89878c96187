"""Write calibration inputs made by a known camera, to try ``redservo calibrate`` and
``redservo calibrate-hand-eye`` and compare what they find with the truth (docs/vision.md).

    python examples/calibration_demo.py calib-demo
    redservo calibrate calib-demo/chessboard/*.png --chessboard 9x6 --square 0.025
    redservo calibrate calib-demo/circles/*.png --circles 7x5 --spacing 0.03
    redservo calibrate-hand-eye calib-demo/eye-in-hand.json
    redservo calibrate-hand-eye calib-demo/eye-to-hand.csv --mount world

The images: a 640x480 camera with radial-tangential distortion sees the pattern at 12 poses
(0.32-0.45 m away, tilted by up to 0.7 rad). The pose pairs: 12 robot poses and the target
pose each would give, with the error of a good pose estimate (0.05 deg, 0.3 mm per axis).
Needs redservo[vision].
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np

from redservo.calibration.synthetic import render_pattern
from redservo.camera import Camera
from redservo.spatial import inverse, make_transform, matrix_to_rotvec

CAMERA = Camera(
    px=600.0, py=601.2, u0=323.3, v0=237.9, width=640, height=480,
    k1=-0.25, k2=0.08, p1=0.001, p2=-0.0007,
)  # fmt: skip
E_M_C = make_transform(rotvec=[0.05, -0.1, 1.5], t=[0.03, -0.02, 0.08])
W_M_C = make_transform(rotvec=[-1.2, -1.2, 1.2], t=[0.95, 0.02, 0.55])


def views(n: int, size: tuple[int, int], spacing: float, seed: int = 1) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    centre = np.array([(size[0] - 1) * spacing / 2, (size[1] - 1) * spacing / 2, 0.0])
    out = []
    for _ in range(n):
        rv = rng.uniform(-0.7, 0.7, 3)
        rv[2] = rng.uniform(-0.3, 0.3)
        R = make_transform(rotvec=rv)[:3, :3]
        off = rng.uniform([-0.06, -0.04], [0.06, 0.04])
        out.append(make_transform(R, np.array([*off, rng.uniform(0.32, 0.45)]) - R @ centre))
    return out


def pairs(mount: str, n: int = 12, seed: int = 3) -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    wMo = make_transform(rotvec=[3.0, 0.1, 0.0], t=[0.6, 0.0, 0.0])
    eMo = make_transform(rotvec=[0.2, 0.1, 0.4], t=[0.0, 0.05, 0.1])
    out = []
    for _ in range(n):
        wMe = make_transform(
            rotvec=np.array([np.pi, 0.0, 0.0]) + rng.uniform(-0.5, 0.5, 3),
            t=rng.uniform([0.3, -0.2, 0.3], [0.6, 0.2, 0.6]),
        )
        cMo = inverse(wMe @ E_M_C) @ wMo if mount == "hand" else inverse(W_M_C) @ wMe @ eMo
        noise = make_transform(rotvec=rng.normal(0, np.radians(0.05), 3), t=rng.normal(0, 3e-4, 3))
        out.append((wMe, cMo @ noise))
    return out


def _row(T: np.ndarray) -> list[float]:
    return [*T[:3, 3].tolist(), *matrix_to_rotvec(T[:3, :3]).tolist()]


def main(out: Path) -> None:
    import cv2

    for pattern, size, spacing in (("chessboard", (9, 6), 0.025), ("circles", (7, 5), 0.03)):
        d = out / pattern
        d.mkdir(parents=True, exist_ok=True)
        for k, cMo in enumerate(views(12, size, spacing)):
            print(f"rendering {d}/view{k:02d}.png", file=sys.stderr, flush=True)
            img = render_pattern(CAMERA, cMo, pattern=pattern, size=size, spacing=spacing)
            cv2.imwrite(str(d / f"view{k:02d}.png"), img)
    hand = [{"wMe": a.tolist(), "cMo": b.tolist()} for a, b in pairs("hand")]
    (out / "eye-in-hand.json").write_text(json.dumps(hand, indent=1) + "\n")
    with (out / "eye-to-hand.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(
            [f"{m}_{c}" for m in ("wMe", "cMo") for c in ("tx", "ty", "tz", "rx", "ry", "rz")]
        )
        for a, b in pairs("world"):
            w.writerow([f"{v:.9g}" for v in (*_row(a), *_row(b))])
    print(f"truth: {CAMERA}")
    print(f"truth: eMc t = {E_M_C[:3, 3]}, rotvec = {matrix_to_rotvec(E_M_C[:3, :3])}")
    print(f"truth: wMc t = {W_M_C[:3, 3]}, rotvec = {matrix_to_rotvec(W_M_C[:3, :3])}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "calib-demo"))
