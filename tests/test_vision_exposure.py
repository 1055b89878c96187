"""The compiled exposure of a scene of dots (redservo.kernels.blob_expose): the frame of
motion_blur.exposed_frame bit for bit as the layers of the general path composited by
Renderer.lazy, whatever the motion (dots overlapping, leaving the image, behind the camera)."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.kernels._jit import COMPILED
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform, rotvec_to_matrix

cv2 = pytest.importorskip("cv2", reason="the renderer needs OpenCV (redservo[vision])")

from redservo.vision import motion_blur  # noqa: E402
from redservo.vision.lazyframe import LazyFrame  # noqa: E402
from redservo.vision.render import Renderer, RenderOptions  # noqa: E402

DOTS = np.array(
    [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]
)


def _frames(compiled: bool, monkeypatch: pytest.MonkeyPatch, opt: RenderOptions) -> list:
    """Whole frames of random exposures (5 instants), the compiled path or the reference."""
    if not compiled:
        monkeypatch.setattr(motion_blur, "_dot_frame", lambda *a: None)
    rng = np.random.default_rng(7)
    r = Renderer(options=opt)
    scene = Scene(
        [
            PointSet("a", DOTS, trajectory=Static(make_transform(t=[0.0, 0.0, 0.8]))),
            PointSet("b", 0.3 * DOTS, trajectory=Static(make_transform(t=[0.05, 0.02, 0.9]))),
        ]
    )
    out = []
    for k in range(40):
        w0, w1 = rng.normal(0, 0.2, 3), rng.normal(0, 0.2, 3)
        t0, t1 = rng.normal(0, 0.15, 3), rng.normal(0, 0.15, 3)
        if k % 10 == 9:
            t1[2] = 0.85  # the camera goes past the dots during the exposure
        poses = [
            make_transform(rotvec_to_matrix((1 - u) * w0 + u * w1), (1 - u) * t0 + u * t1)
            for u in np.linspace(0.0, 1.0, 5)
        ]
        frame = motion_blur.exposed_frame(r, scene, [(T, 0.1 * k) for T in poses])
        assert isinstance(frame, LazyFrame)
        out.append(frame.full().copy())
    monkeypatch.undo()
    return out


@pytest.mark.skipif(not COMPILED, reason="the compiled exposure needs numba")
@pytest.mark.parametrize(
    "opt",
    [RenderOptions(noise_px=4.0, blur_px=0.8, seed=1), RenderOptions(), RenderOptions(blur_px=1.5)],
)
def test_the_compiled_exposure_is_the_layers_frame_bit_for_bit(
    opt: RenderOptions, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = {"n": 0}
    real = motion_blur._dot_frame

    def counted(*args: object) -> object:
        out = real(*args)  # type: ignore[arg-type]
        calls["n"] += out is not None
        return out

    monkeypatch.setattr(motion_blur, "_dot_frame", counted)
    fast = _frames(True, monkeypatch, opt)
    assert calls["n"] == 40
    ref = _frames(False, monkeypatch, opt)
    lit = 0
    for k, (a, b) in enumerate(zip(fast, ref)):
        assert np.array_equal(a, b), f"frame {k}: {np.count_nonzero(a != b)} pixels differ"
        lit += int((a > np.median(a) + 30).sum())
    assert lit > 1000, lit  # dots were drawn
