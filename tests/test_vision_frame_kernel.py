"""The dot tracker's frame kernel: every tracked dot of a frame in one compiled call
(redservo.kernels.blob_frame), the same tracks bit for bit as the dot-by-dot path."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform, rotvec_to_matrix

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.kernels._jit import COMPILED  # noqa: E402
from redservo.kernels.blob_frame import _geometry  # noqa: E402
from redservo.vision import tracking  # noqa: E402
from redservo.vision.dotseq import dot_sequence  # noqa: E402
from redservo.vision.fastdot import similarity_prediction  # noqa: E402
from redservo.vision.lazyframe import LazyFrame  # noqa: E402
from redservo.vision.render import Renderer, RenderOptions  # noqa: E402
from redservo.vision.tracking import ImageDotTracker  # noqa: E402

DOTS = np.array(
    [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]
)


def _tracks(frames: list, uv0: np.ndarray, kernel: bool, monkeypatch: pytest.MonkeyPatch) -> list:
    """Every frame's DotTrack and dot state, with or without the frame kernel."""
    counted = {"accepted": 0}
    real = tracking.track_tracked

    def frame(*args: object) -> object:
        out = real(*args)  # type: ignore[arg-type]
        counted["accepted"] += out is not None
        return out

    monkeypatch.setattr(tracking, "track_tracked", frame if kernel else (lambda *a: None))
    tracker = ImageDotTracker(4)
    tracker.start(frames[0], uv0)
    out = []
    for img in frames[1:]:
        st = tracker.update(img)
        dots = [
            (*d.uv, *d.vel, d.level, d.background, d.area, d.size, d.lost) for d in tracker._dots
        ]
        out.append((st.uv, st.detected, st.reasons, st.gone, np.array(dots)))
    monkeypatch.setattr(tracking, "track_tracked", real)
    return [out, counted["accepted"]]


def _same(a: list, b: list) -> None:
    for k, (x, y) in enumerate(zip(a, b)):
        assert np.array_equal(x[0], y[0]), f"frame {k + 1}: uv differ"
        assert np.array_equal(x[1], y[1]) and x[2] == y[2] and x[3] == y[3], f"frame {k + 1}"
        assert np.array_equal(x[4], y[4], equal_nan=True), f"frame {k + 1}: dot states differ"


@pytest.mark.skipif(not COMPILED, reason="the frame kernel runs compiled only")
@pytest.mark.parametrize(
    "kind", ["nested", "gradient", "motion_blur", "occlusion", "bright_merge", "digits"]
)
def test_the_frame_kernel_tracks_bit_for_bit_as_dot_by_dot(
    kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    seq = list(dot_sequence(kind, 60))
    frames = [f.image for f in seq]
    fast, accepted = _tracks(frames, seq[0].uv, True, monkeypatch)
    slow, none = _tracks(frames, seq[0].uv, False, monkeypatch)
    _same(fast, slow)
    assert none == 0
    assert accepted >= 0.4 * (len(frames) - 1), f"{kind}: the frame kernel took {accepted}"


@pytest.mark.skipif(not COMPILED, reason="the frame kernel runs compiled only")
def test_the_frame_kernel_on_lazy_frames_reads_the_full_frames_pixels(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Rendered frames (noise, blur) of a moving target: tracked in lazy frames (the kernel
    # composes its windows) and in the whole frames, identically; the composed windows are
    # the whole frame's pixels.
    r = Renderer(options=RenderOptions(noise_px=3.0, blur_px=0.8, seed=4))
    lazy, whole, uv0 = [], [], None
    for k in range(25):
        T = make_transform(rotvec_to_matrix([0.1, -0.05, 0.02 * k]), [0.002 * k, 0.0, 0.8])
        scene = Scene([PointSet("t", DOTS, trajectory=Static(T))])
        frame = r.lazy_frame(scene, np.eye(4))
        assert isinstance(frame, LazyFrame)
        lazy.append(frame)
        if uv0 is None:
            P = DOTS @ T[:3, :3].T + T[:3, 3]
            uv0 = r.optics.to_pixel(P[:, :2] / P[:, 2:])
    fast, accepted = _tracks(lazy, uv0, True, monkeypatch)
    assert accepted == len(lazy) - 1
    for frame in lazy:
        whole.append(frame.full().copy())  # after tracking: the kernel's windows are kept
        done = frame._done[:-1]
        assert done, "the frame kernel marks its windows composed"
        for r0, r1, c0, c1 in done:
            assert np.array_equal(frame.pixels[r0:r1, c0:c1], whole[-1][r0:r1, c0:c1])
    slow, _ = _tracks(whole, uv0, False, monkeypatch)
    _same(fast, slow)


@pytest.mark.skipif(not COMPILED, reason="compiled only: plain Python's math.hypot is not libm's")
def test_the_geometry_is_pythons_complex_arithmetic() -> None:
    rng = np.random.default_rng(2)
    for _ in range(200):
        n = int(rng.integers(3, 7))
        ref = rng.uniform(0, 640, (n, 2))
        cur = ref + rng.normal(0, 5, (n, 2))
        target = int(rng.integers(n))
        found = np.array([j for j in range(n) if j != target])
        z, spread = similarity_prediction(
            [complex(*p) for p in ref.tolist()],
            [complex(*p) for p in cur[found].tolist()],
            found.tolist(),
        )
        gu, gv, s = _geometry(ref, cur[found].copy(), found, target)
        assert (gu, gv, s) == (z[target].real, z[target].imag, spread)
