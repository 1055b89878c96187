"""The simulation loop's image check in one compiled call (``kernels/in_image``, issue 28,
item 6): the answer of the numpy code it replaces on fuzzed points, margins and cameras
(points on the image's edges, behind the camera, a margin beyond the image), and that
code's own error or answer where the kernel does not decide (an overflowing point, a lens
with distortion)."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.camera import Camera
from redservo.errors import ShapeError
from redservo.simulation import loop


def _numpy_in_image(cam: Camera, P: np.ndarray, margin_px: float) -> bool:
    """The code the kernel replaced."""
    if np.any(P[:, 2] <= 1e-9):
        return False
    xy = P[:, :2] / P[:, 2:3]
    return bool(np.all(cam.in_image(xy, margin_px=margin_px)))


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_image_check_answers_as_the_numpy_code(seed: int) -> None:
    rng = np.random.default_rng(seed)
    focal = rng.uniform(300, 900, 2)
    cam = Camera(
        px=float(focal[0]),
        py=float(focal[1]),
        u0=float(rng.uniform(250, 400)),
        v0=float(rng.uniform(200, 300)),
    )
    answers = set()
    for i in range(2000):
        n = int(rng.integers(1, 6))
        Z = rng.uniform(0.05, 2.0, n)
        if i % 17 == 0:
            Z[0] = float(rng.choice([0.0, 1e-9, -0.3, 2e-9]))
        u = rng.uniform(-60, cam.width + 60, n)
        v = rng.uniform(-60, cam.height + 60, n)
        if i % 5 == 0:  # exactly on an edge of the image less the margin
            u[0] = float(rng.choice([0.0, cam.width, 3.0, cam.width - 3.0]))
        x, y = (u - cam.u0) / cam.px, (v - cam.v0) / cam.py
        P = np.column_stack((x * Z, y * Z, Z))
        margin = float(rng.choice([0.0, 3.0, -5.0, 2.5]))
        want = _numpy_in_image(cam, P, margin)
        assert loop._in_image(cam, P, margin) is want
        answers.add(want)
    assert answers == {True, False}


def test_what_the_kernel_does_not_decide_takes_the_numpy_code() -> None:
    cam = Camera()
    huge = np.array([[1e308, 0.0, 1e-8]])  # X/Z overflows: numpy's check names it
    with pytest.raises(ShapeError):
        loop._in_image(cam, huge, 0.0)
    lens = Camera(k1=0.1)
    P = np.array([[0.3, 0.2, 0.5], [-0.1, 0.05, 0.8]])
    assert loop._in_image(lens, P, 0.0) is _numpy_in_image(lens, P, 0.0)
