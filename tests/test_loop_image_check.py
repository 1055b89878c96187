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


@pytest.mark.parametrize("seed", range(8))
def test_the_targets_in_one_compiled_call_answer_as_the_check_per_target(seed: int) -> None:
    """``simulation/loop_image.ImageCheck`` (the targets' camera points and the test in one
    compiled call) answers as the per-target check it replaces (``visible_points`` then
    ``_in_image`` for each target), on fuzzed camera poses around two point sets, one of
    them moving, with the robot's base off the world origin (odd seeds) or at it, and the
    camera points are ``visible_points``' bit for bit."""
    from redservo.control.objectives import visible_points
    from redservo.kernels.dot_pixels import dot_points
    from redservo.scene import ConstantVelocity, PointSet, Scene, Static
    from redservo.simulation.loop_image import ImageCheck
    from redservo.spatial import make_transform

    rng = np.random.default_rng(seed)
    wMb = (
        make_transform(t=rng.normal(size=3) * 0.3, rotvec=rng.normal(size=3)) if seed % 2 else None
    )
    a = PointSet(
        "a", rng.normal(size=(4, 3)) * 0.05, trajectory=Static(make_transform(t=(0.0, 0.0, 0.8)))
    )
    moving = ConstantVelocity(make_transform(t=(0.1, 0.0, 0.9)), v=np.array([0.05, -0.02, 0.0]))
    b = PointSet("b", rng.normal(size=(3, 3)) * 0.05, trajectory=moving)
    scene = Scene([a, b], wMb=wMb)
    cam, margin = Camera(), float(rng.choice([0.0, 4.0, 20.0]))
    check = ImageCheck(scene, ["a", "b"], cam, margin)
    assert check.fast
    answers = set()
    for i in range(400):
        t = 0.04 * i
        wMc = make_transform(t=rng.normal(size=3) * 0.15, rotvec=rng.normal(size=3) * 0.25)
        bMc = (np.linalg.inv(scene.wMb) @ wMc) if seed % 2 else wMc
        want = all(_numpy_in_image(cam, visible_points(scene, n, bMc, t), margin) for n in "ab")
        assert check(bMc, t) is want, i
        answers.add(want)
        wMo = check._poses(t)
        P = dot_points(bMc[None], wMo, check.bMw, check.has_base, check.pts, check.starts)[0]
        ref = np.concatenate([visible_points(scene, n, bMc, t) for n in "ab"])
        assert P.tobytes() == ref.tobytes(), i
    assert answers == {True, False}
