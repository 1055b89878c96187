"""The image dot tracker's fast path (issue 28): compiled window search, predicted motion."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.errors import ConfigurationError, ShapeError
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform, rotvec_to_matrix

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.kernels.blob import _dilate  # noqa: E402
from redservo.kernels.blob_shape import shape_ok  # noqa: E402
from redservo.vision import fastdot, tracking  # noqa: E402
from redservo.vision.blobs import DEFAULT_SHAPE, shape_reason  # noqa: E402
from redservo.vision.dots import detect_dots  # noqa: E402
from redservo.vision.dotseq import dot_sequence  # noqa: E402
from redservo.vision.render import Renderer, RenderOptions  # noqa: E402
from redservo.vision.tracking import ImageDotTracker  # noqa: E402

DOTS = np.array(
    [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]
)


def _shot(r: Renderer, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(image, true dot positions (4, 2) px) of the target at pose ``T``."""
    P = DOTS @ T[:3, :3].T + T[:3, 3]
    img = r.render(Scene([PointSet("t", DOTS, trajectory=Static(T))]), np.eye(4))
    return img, r.optics.to_pixel(P[:, :2] / P[:, 2:])


def _counting(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Count the fast path's calls and hits (dot by dot: the frame kernel switched off)."""
    calls = {"calls": 0, "hits": 0}
    real = fastdot.window_blob

    def counted(*args: object, **kwargs: object) -> object:
        out = real(*args, **kwargs)  # type: ignore[arg-type]
        calls["calls"] += 1
        calls["hits"] += out is not None
        return out

    monkeypatch.setattr(tracking, "window_blob", counted)
    monkeypatch.setattr(tracking, "track_tracked", lambda *a: None)  # dot by dot
    return calls


def test_windowed_centroids_match_full_frame_centroids(monkeypatch: pytest.MonkeyPatch) -> None:
    # Rendered frames (blur, noise) of a moving target: each dot found by the compiled
    # window search is within 0.05 px of the full-frame detector's centroid.
    calls = _counting(monkeypatch)
    r = Renderer(options=RenderOptions(noise_px=1.0, blur_px=0.7, seed=3))
    tracker = ImageDotTracker(4)
    worst = 0.0
    for k in range(30):
        T = make_transform(rotvec_to_matrix([0.1, -0.05, 0.03 * k]), [0.003 * k, 0.0, 0.8])
        img, truth = _shot(r, T)
        st = tracker.start(img, truth) if k == 0 else tracker.update(img)
        assert st.detected.all()
        full = detect_dots(img, threshold=140.0).uv
        assert full.shape == (4, 2)
        d = np.linalg.norm(st.uv[:, None, :] - full[None, :, :], axis=2).min(axis=1)
        worst = max(worst, float(d.max()))
    assert calls["hits"] == calls["calls"] == 29 * 4, calls
    assert worst <= 0.05, f"windowed vs full-frame centroids differ by {worst:.3f} px"


@pytest.mark.parametrize("kind", ["nested", "gradient", "motion_blur", "digits"])
def test_fast_path_agrees_with_the_reference_search(
    kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    frames = list(dot_sequence(kind, 30))
    ref_tracker, fast_tracker = ImageDotTracker(4), ImageDotTracker(4)
    ref_tracker.start(frames[0].image, frames[0].uv)
    fast_tracker.start(frames[0].image, frames[0].uv)
    calls = _counting(monkeypatch)
    fast = [fast_tracker.update(f.image) for f in frames[1:]]
    monkeypatch.setattr(tracking, "window_blob", lambda *a, **k: None)
    ref = [ref_tracker.update(f.image) for f in frames[1:]]
    assert calls["hits"] >= 0.9 * calls["calls"], f"{kind}: fast path rarely used {calls}"
    for a, b in zip(fast, ref):
        assert (a.detected == b.detected).all()
        assert np.abs(a.uv - b.uv)[a.detected].max(initial=0.0) <= 0.05


def test_a_predicted_shift_keeps_a_dot_that_jumps_beyond_the_gate() -> None:
    # The target stands still, then jumps 60 px in one frame (a fast camera motion):
    # the constant-velocity prediction loses every dot; the shift predicted by the caller
    # (from the commanded twist) keeps them.
    r = Renderer(options=RenderOptions(noise_px=1.0, blur_px=0.5, seed=1))
    T0 = make_transform(t=[0.0, 0.0, 0.8])
    T1 = make_transform(t=[60.0 * 0.8 / r.camera.px, 0.0, 0.8])
    (img0, uv0), (img1, uv1) = _shot(r, T0), _shot(r, T1)
    blind, guided = ImageDotTracker(4), ImageDotTracker(4)
    for tr in (blind, guided):
        tr.start(img0, uv0)
        assert tr.update(img0).detected.all()
    st = blind.update(img1)
    kept = st.detected & (np.hypot(*(st.uv - uv1).T) < 0.5)
    assert kept.sum() <= 1  # lost, or one taken for another's blob
    st = guided.update(img1, shift=uv1 - uv0)
    assert st.detected.all()
    assert np.abs(st.uv - uv1).max() < 0.1
    # a NaN row: no prediction for that dot, the constant-velocity one is used
    part = ImageDotTracker(4)
    part.start(img0, uv0)
    shift = uv1 - uv0
    shift[2] = np.nan
    st = part.update(img1, shift=shift)
    assert st.detected[[0, 1, 3]].all()


def test_a_bad_shift_is_refused() -> None:
    r = Renderer()
    img, uv = _shot(r, make_transform(t=[0.0, 0.0, 0.8]))
    tr = ImageDotTracker(4)
    tr.start(img, uv)
    with pytest.raises(ShapeError, match=r"shift must have shape \(4, 2\)"):
        tr.update(img, shift=np.zeros((3, 2)))
    with pytest.raises(ConfigurationError, match="shift must be finite"):
        tr.update(img, shift=np.full((4, 2), np.inf))


def test_compiled_dilation_is_opencvs() -> None:
    rng = np.random.default_rng(0)
    for p in (1, 2, 3, 5):
        discs = fastdot._discs(p)
        for _ in range(20):
            own = rng.random((25, 31)) > 0.85
            for disc in discs:
                ref = cv2.dilate(own.astype(np.uint8), disc) > 0
                assert (ref == _dilate(own, disc)).all()


def test_compiled_shape_test_accepts_only_what_the_reference_accepts() -> None:
    rng = np.random.default_rng(1)
    accepted = 0
    for k in range(200):
        img = np.zeros((40, 40), np.uint8)
        if k % 3 == 0:
            axes = (int(rng.integers(2, 12)), int(rng.integers(2, 12)))
            cv2.ellipse(img, (20, 20), axes, float(rng.uniform(0, 180)), 0, 360, 255, -1)
        elif k % 3 == 1:
            cv2.putText(img, str(k % 10), (8, 32), cv2.FONT_HERSHEY_SIMPLEX, 1.0, 255, 3)
        else:
            cv2.circle(img, (20, 20), int(rng.integers(5, 12)), 255, -1)
            cv2.circle(img, (20, 20), int(rng.integers(1, 4)), 0, -1)  # a ring
        _, labels = cv2.connectedComponents(img, connectivity=8)
        own = labels == 1 + int(np.argmax(np.bincount(labels.ravel())[1:]))
        ys, xs = np.nonzero(own)
        box = own[ys.min() - 1 : ys.max() + 2, xs.min() - 1 : xs.max() + 2]
        fast = shape_ok(np.ascontiguousarray(box), *DEFAULT_SHAPE)  # C, as the sensor's
        if fast:
            accepted += 1
            assert shape_reason(box[1:-1, 1:-1], DEFAULT_SHAPE) == "", k
    assert accepted >= 50  # the ellipses and discs


@pytest.mark.parametrize("predict", [True, False])
def test_the_image_sensor_follows_a_fast_camera_rotation(
    predict: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The camera turns 0.1 rad in one frame (about 60 px of image motion): the sensor
    # centres each dot's window on the motion its camera made, and keeps every dot.
    from redservo.features import PointFeature
    from redservo.task import TaskTerm, VisualTask
    from redservo.vision import sensor as sensor_mod
    from redservo.vision.sensor import ImageSensor

    if not predict:  # what the constant-velocity guess alone does
        monkeypatch.setattr(sensor_mod, "camera_shift", lambda *a: None)
    T = make_transform(t=[0.0, 0.0, 0.8])
    scene = Scene([PointSet("t", DOTS, trajectory=Static(T))])
    terms = [TaskTerm(PointFeature(p), "t") for p in DOTS]
    task = VisualTask.from_desired_poses(terms, {"t": make_transform(t=[0.0, 0.0, 0.6])})
    sensor = ImageSensor(noise_px=0.5, blur_px=0.5)
    sensor.read(task, scene, np.eye(4), 0.0)
    sensor.read(task, scene, np.eye(4), 0.04)
    bMc = make_transform(rotvec_to_matrix([0.0, 0.1, 0.0]))
    got = sensor.read(task, scene, bMc, 0.08)
    P = DOTS @ T[:3, :3].T + T[:3, 3]
    P = (P - bMc[:3, 3]) @ bMc[:3, :3]  # in the turned camera's frame
    truth = sensor.renderer.optics.to_pixel(P[:, :2] / P[:, 2:])
    kept = np.hypot(*(sensor.dots_uv - truth).T) < 0.2
    if predict:
        assert got.lost == () and kept.all(), got.reason
    else:
        assert not kept.all()
