"""The exposure's dot pixels in one compiled call (kernels/dot_pixels.py) are the numpy
code's bit for bit: in front, behind, on and off the image's borders, NaN; and a realistic
exposure's frame is the same with and without it (issue 28, image campaigns' speed)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("cv2", reason="the image sensor needs redservo[vision]")

from redservo.camera import Camera
from redservo.kernels._jit import COMPILED
from redservo.vision import motion_blur
from redservo.vision.lazyframe import pixels
from redservo.vision.render import Renderer, RenderOptions


def _points(rng: np.random.Generator) -> np.ndarray:
    """(5, 40, 3) camera points: in front, behind, at the near limit, far off the image,
    on the borders, NaN."""
    P = np.column_stack(
        [rng.uniform(-0.8, 0.8, 200), rng.uniform(-0.6, 0.6, 200), rng.uniform(-0.2, 2.0, 200)]
    ).reshape(5, 40, 3)
    P[0, :4, 2] = [0.0, 1e-9, -1.0, 1e-3]
    P[1, :3] = [[np.nan, 0.0, 1.0], [0.0, np.nan, 1.0], [0.0, 0.0, np.nan]]
    P[2, :4, :2] = [[320 / 600, 0.0], [-320 / 600, 0.0], [0.0, 240 / 600], [0.0, -240 / 600]]
    P[2, :4, 2] = 1.0
    P[3, :2, :2] = [[1e6, 0.0], [0.0, -1e6]]
    return P


@pytest.mark.skipif(not COMPILED, reason="the compiled path needs numba")
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dot_pixels_are_the_numpy_codes_bit_for_bit(
    monkeypatch: pytest.MonkeyPatch, seed: int
) -> None:
    renderer = Renderer(Camera(), RenderOptions())
    P = _points(np.random.default_rng(seed))
    fast = motion_blur._dot_pixels(renderer, P)
    monkeypatch.setattr(motion_blur, "COMPILED", False)
    slow = motion_blur._dot_pixels(renderer, P)
    for a, b in zip(fast, slow):
        assert a.dtype == b.dtype and a.shape == b.shape
        assert a.tobytes() == b.tobytes()
    assert fast[3].any() and not fast[3].all()


@pytest.mark.skipif(not COMPILED, reason="the compiled path needs numba")
def test_an_exposed_frame_is_the_same_with_and_without_the_kernel(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from redservo.campaign import load_campaign
    from redservo.experiment.build import build
    from redservo.experiment.camera_presets import camera_overrides
    from redservo.scenario import apply_overrides

    defn = load_campaign("panda-near-limits")
    scenario = apply_overrides(defn.scenario, camera_overrides("realistic"))
    exp = build(scenario)
    bMc = exp.robot.kinematics(exp.q0, check_limits=False)[0]
    shifted = bMc.copy()
    shifted[:3, 3] += [0.004, -0.003, 0.002]
    samples = [(bMc if k < 3 else shifted, 0.002 * k) for k in range(5)]

    def frame() -> Any:
        renderer = exp.sensor.renderer
        renderer.reset()
        return pixels(motion_blur.exposed_frame(renderer, exp.scene, samples))

    fast = frame()
    real = motion_blur.dot_pixels
    calls = [0]

    def counted(*a: Any) -> Any:
        calls[0] += 1
        return real(*a)

    monkeypatch.setattr(motion_blur, "dot_pixels", counted)
    assert np.array_equal(frame(), fast) and calls[0] == 1
    monkeypatch.setattr(motion_blur, "COMPILED", False)  # the layers' path, numpy's pixels
    monkeypatch.setattr(motion_blur, "dot_pixels", lambda *a: pytest.fail("kernel used"))
    assert np.array_equal(frame(), fast)


@pytest.mark.skipif(not COMPILED, reason="the compiled path needs numba")
@pytest.mark.parametrize("wMb", [None, "offset"])
def test_dot_points_are_scene_cmo_products_bit_for_bit(
    monkeypatch: pytest.MonkeyPatch, wMb: str | None
) -> None:
    """Two point sets, one moving, the base at the world origin or not: the compiled camera
    points are the numpy products (Scene.cMo's, then ``pts Rᵀ + t``) bit for bit."""
    from redservo.scene import ConstantVelocity, PointSet, Scene
    from redservo.spatial import make_transform, rotvec_to_matrix

    rng = np.random.default_rng(3)
    base = (
        None
        if wMb is None
        else make_transform(rotvec_to_matrix([0.1, -0.2, 0.3]), [0.3, -0.1, 0.05])
    )
    moving = ConstantVelocity(
        make_transform(rotvec_to_matrix([0.2, 0.1, 0.0]), [0.1, 0.0, 0.9]),
        [0.02, 0.0, -0.01],
        [0.0, 0.3, 0.1],
    )
    scene = Scene(
        [
            PointSet("a", rng.uniform(-0.1, 0.1, (4, 3))),
            PointSet("b", rng.uniform(-0.1, 0.1, (5, 3)), trajectory=moving),
        ],
        wMb=base,
    )
    sets = [(name, scene.object(name)) for name in scene.names]
    samples = []
    for k in range(5):
        T = make_transform(rotvec_to_matrix(rng.normal(0.0, 0.3, 3)), rng.normal(0.0, 0.2, 3))
        samples.append((T, 0.01 * k))
    fast = motion_blur._dot_points(scene, sets, samples, 9)
    monkeypatch.setattr(motion_blur, "COMPILED", False)
    slow = motion_blur._dot_points(scene, sets, samples, 9)
    assert fast.shape == slow.shape == (5, 9, 3) and fast.tobytes() == slow.tobytes()
    for i, (T, t) in enumerate(samples):  # and Scene.cMo's own numbers
        cMo = scene.cMo("b", T, t)
        assert np.array_equal(slow[i, 4:], scene.object("b").points @ cMo[:3, :3].T + cMo[:3, 3])
