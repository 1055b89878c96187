"""Frames computed only where they are read (redservo.vision.lazyframe): every window is bit
for bit the crop of the whole frame, noise, blur, motion blur and light included, and the
image sensor on them measures exactly what it measures on whole frames."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.features import MomentFeatures, PointFeature
from redservo.scene import PointSet, Scene, Sphere, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask
from redservo.vision import ImageSensor
from redservo.vision import motion_blur as mb
from redservo.vision.lazyframe import LazyFrame
from redservo.vision.render import Renderer, RenderOptions
from redservo.vision.tracking import ImageDotTracker

DOTS = np.array(
    [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]
)
OPTIONS = [
    RenderOptions(noise_px=4.0, blur_px=0.8),
    RenderOptions(noise_px=2.0, blur_px=1.3, texture=True, seed=5),
    RenderOptions(),
    RenderOptions(noise_px=3.0, k1=-0.2),
]


def _scene(sphere: bool = False) -> Scene:
    objs: list[Any] = [PointSet("target", DOTS, trajectory=Static(make_transform(t=[0, 0, 0.6])))]
    if sphere:
        objs.append(Sphere("ball", 0.03, trajectory=Static(make_transform(t=[0.05, 0.0, 0.8]))))
    return Scene(objs)


def _poses(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    return [
        make_transform(rotvec=rng.normal(size=3) * 0.1, t=rng.uniform(-0.25, 0.25, 3))
        for _ in range(n)
    ]


@pytest.mark.parametrize("opt", OPTIONS)
@pytest.mark.parametrize("sphere", [False, True])
def test_every_window_is_the_crop_of_the_whole_frame(opt: RenderOptions, sphere: bool) -> None:
    rng = np.random.default_rng(1)
    lazy, whole = Renderer(None, opt), Renderer(None, opt)  # the same random stream
    for bMc in _poses(rng, 12):
        frame = lazy.lazy_frame(_scene(sphere), bMc, 0.0)
        full = whole.render(_scene(sphere), bMc, 0.0)
        assert isinstance(frame, LazyFrame) and frame.shape == full.shape
        for _ in range(6):  # random windows, overlapping and cut by the border
            r0, c0 = int(rng.integers(-20, 470)), int(rng.integers(-20, 630))
            r1, c1 = r0 + int(rng.integers(1, 90)), c0 + int(rng.integers(1, 90))
            got = frame.region(r0, r1, c0, c1)
            assert np.array_equal(got, full[max(r0, 0) : r1, max(c0, 0) : c1])
        assert np.array_equal(np.asarray(frame), full)  # and the whole, computed at last


def test_the_noise_is_each_frames_own_and_reproducible_per_pixel() -> None:
    opt = RenderOptions(noise_px=4.0, blur_px=0.8)
    a, b = Renderer(None, opt), Renderer(None, opt)
    first = a.lazy_frame(_scene(), np.eye(4), 0.0)
    second = a.lazy_frame(_scene(), np.eye(4), 0.0)
    assert isinstance(first, LazyFrame) and isinstance(second, LazyFrame)
    assert not np.array_equal(first.region(0, 40, 0, 40), second.region(0, 40, 0, 40))
    # The same frame of a fresh renderer of the same seed, read in another order: equal.
    again = b.lazy_frame(_scene(), np.eye(4), 0.0)
    assert isinstance(again, LazyFrame)
    assert np.array_equal(again.region(20, 40, 20, 40), first.region(20, 40, 20, 40))
    b.reset()
    assert np.array_equal(np.asarray(b.render(_scene(), np.eye(4), 0.0)), np.asarray(first))


@pytest.mark.parametrize("opt", OPTIONS[:2])
def test_a_motion_blurred_exposure_is_the_same_through_the_dots_fast_path(
    opt: RenderOptions, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(2)
    scene = Scene(
        [
            PointSet("target", DOTS, trajectory=Static(make_transform(t=[0, 0, 0.6]))),
            PointSet("near", DOTS[:2] * 0.5, trajectory=Static(make_transform(t=[0, 0.02, 0.5]))),
        ]
    )
    for T in _poses(rng, 10):
        samples = [
            (T @ make_transform(rotvec=[0, 0, 0.03 * i], t=[0.01 * i, 0, 0]), 0.0) for i in range(5)
        ]
        fast = np.asarray(mb.exposed_frame(Renderer(None, opt), scene, samples))
        with monkeypatch.context() as m:
            m.setattr(mb, "_dot_layers", lambda *a: None)  # the general path, layer by layer
            general = np.asarray(mb.exposed_frame(Renderer(None, opt), scene, samples))
        assert np.array_equal(fast, general)


def test_the_light_gain_of_the_reproductions_is_applied_per_window() -> None:
    from redservo.camera import Camera
    from redservo.reproduction.imaging import Imaging, image_sensor

    sensor = image_sensor(Camera(), Imaging(noise_px=2.0, blur_px=0.8, gradient=0.15), seed=3)
    other = image_sensor(Camera(), Imaging(noise_px=2.0, blur_px=0.8, gradient=0.15), seed=3)
    frame = sensor.renderer.lazy_frame(_scene(), np.eye(4), 0.0)
    full = other.renderer.render(_scene(), np.eye(4), 0.0)
    assert isinstance(frame, LazyFrame)
    assert np.array_equal(frame.region(100, 380, 150, 500), full[100:380, 150:500])
    plain = Renderer(None, sensor.renderer.options).render(_scene(), np.eye(4), 0.0)
    assert other.renderer.gain is not None and not np.array_equal(full, plain)  # it lit


@pytest.mark.parametrize("moments", [False, True])
def test_the_image_sensor_measures_the_same_on_windows_as_on_whole_frames(
    moments: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    desired = {"target": make_transform(t=[0, 0, 0.5])}
    terms = (
        [TaskTerm(MomentFeatures.at_desired_pose(DOTS, desired["target"]), "target")]
        if moments
        else [TaskTerm(PointFeature(p), "target") for p in DOTS]
    )
    task = VisualTask.from_desired_poses(terms, desired)
    path = [
        make_transform(rotvec=[0, 0, 0.01 * k], t=[0.004 * k, -0.002 * k, 0]) for k in range(30)
    ]
    lazy = ImageSensor(noise_px=4.0, blur_px=0.8)
    got = [lazy.read(task, _scene(), T, 0.1 * k) for k, T in enumerate(path)]
    assert isinstance(got[-1].image, LazyFrame)
    whole = ImageSensor(noise_px=4.0, blur_px=0.8)
    monkeypatch.setattr(Renderer, "lazy_frame", lambda self, *a: self.render(*a))  # whole frames
    want = [whole.read(task, _scene(), T, 0.1 * k) for k, T in enumerate(path)]
    for a, b in zip(got, want):
        assert a.s is not None and b.s is not None and np.array_equal(a.s, b.s)
        assert a.lost == b.lost and a.reason == b.reason


def test_the_tracker_reads_a_lazy_frame_only_around_its_dots() -> None:
    renderer = Renderer(None, RenderOptions(noise_px=4.0, blur_px=0.8))
    frame = renderer.lazy_frame(_scene(), np.eye(4), 0.0)
    assert isinstance(frame, LazyFrame)
    P = DOTS + np.array([0.0, 0.0, 0.6])
    uv = renderer.optics.to_pixel(P[:, :2] / P[:, 2:])
    tracker = ImageDotTracker(4)
    tracker.start(frame, uv)
    nxt = renderer.lazy_frame(_scene(), make_transform(t=[0.002, 0.0, 0.0]), 0.0)
    assert isinstance(nxt, LazyFrame)
    track = tracker.update(nxt)
    assert track.detected.all()
    read = sum((r1 - r0) * (c1 - c0) for r0, r1, c0, c1 in nxt._done)
    assert read < 0.05 * 640 * 480  # four windows, not the frame


def test_the_compose_and_pose_kernels_agree_with_their_plain_python() -> None:
    from redservo.kernels import interp
    from redservo.kernels.compose import compose_region

    rng = np.random.default_rng(4)
    bgb = rng.uniform(0, 255, (40, 50)).astype(np.float32)
    field = rng.standard_normal((80, 100)).astype(np.float32)
    boxes = np.array([[5, 15, 10, 22, 0], [20, 30, 30, 45, 120]], dtype=np.int64)
    deltas = rng.uniform(-80, 200, 120 + 150).astype(np.float32)
    gain = rng.uniform(0.8, 1.2, (40, 50)).astype(np.float32)
    for rect, has_gain in (((0, 40, 0, 50), False), ((3, 27, 8, 41), True)):
        args = (np.array(rect), bgb, field, np.array([7, 11]), 4.0, boxes, deltas, gain, has_gain)
        plain = getattr(compose_region, "py_func", compose_region)(*args)
        assert np.array_equal(compose_region(*args), plain)
    f = interp.interpolate_pose
    T0 = make_transform(rotvec=[0.3, -0.2, 0.1], t=[0.1, 0.2, 0.3])
    T1 = make_transform(rotvec=[0.31, -0.18, 0.12], t=[0.11, 0.2, 0.29])
    assert np.allclose(f(T0, T1, 0.3), getattr(f, "py_func", f)(T0, T1, 0.3), atol=1e-15)
    assert np.allclose(f(T0, T1, 1.0), T1, atol=1e-12) and np.array_equal(f(T0, T1, 0.0), T0)
