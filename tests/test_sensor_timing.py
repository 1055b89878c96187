"""A camera's timing around any sensor (redservo.sensors.timing): frames at the camera's rate,
stamped with their exposure time, available only after the latency, held in between."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest

from redservo.errors import ConfigurationError
from redservo.sensors import FrameNoise, IdealSensor, SensorReading
from redservo.sensors.timing import EXPOSURE_SAMPLES, CameraTiming, TimedSensor, timed


class _Clock(IdealSensor):
    """Measures the time (s) and the camera's x (m) it was read at: s = [t, x]."""

    def __init__(self) -> None:
        self.calls: list[float] = []
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1

    def read(self, task: Any, scene: Any, bMc: Any, t: float) -> SensorReading:
        self.calls.append(t)
        return SensorReading(np.array([t, bMc[0, 3]]), ())


def _pose(x: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = x
    return T


def _run(sensor: TimedSensor, dt: float, steps: int, speed: float = 0.0) -> list[SensorReading]:
    """Read at every step, the camera moving along x at ``speed`` m/s from t = 0."""
    return [sensor.read(None, None, _pose(speed * k * dt), k * dt) for k in range(steps)]  # type: ignore[arg-type]


def test_frames_come_at_the_camera_rate_stamped_and_held_between_frames() -> None:
    inner = _Clock()
    out = _run(TimedSensor(inner, CameraTiming(rate=25.0), 0.01), 0.01, 13)
    stamps = [r.stamp for r in out]
    # A frame every 40 ms, available at once (no latency), held over the steps in between.
    assert stamps == pytest.approx([0.0] * 4 + [0.04] * 4 + [0.08] * 4 + [0.12])
    assert inner.calls == pytest.approx([0.0, 0.04, 0.08, 0.12])


def test_nothing_is_used_before_it_exists_with_a_latency() -> None:
    dt, latency = 0.01, 0.066
    out = _run(TimedSensor(_Clock(), CameraTiming(rate=30.0, latency=latency), dt), dt, 40, 0.1)
    for k, r in enumerate(out):
        t = k * dt
        assert r.stamp is not None and r.stamp + latency <= t + 1e-9  # it exists at t
        # ... and it is the newest frame that exists: the next one is not available yet.
        assert r.stamp + 1.0 / 30.0 + latency > t - 1e-9
        # Before the start the robot was at rest at q0 and the world frozen at t = 0.
        assert r.s is not None and r.s[0] == pytest.approx(max(r.stamp, 0.0))
        assert r.s[1] == pytest.approx(0.1 * max(r.stamp, 0.0))  # pose interpolated at stamp


def test_the_default_timing_is_perfect_and_leaves_the_sensor_alone() -> None:
    assert CameraTiming().perfect
    sensor = IdealSensor()
    assert timed(sensor, CameraTiming(), 0.04) is sensor
    assert timed(None, CameraTiming(), 0.04) is None
    wrapped = timed(None, CameraTiming(latency=0.05), 0.04)
    assert isinstance(wrapped, TimedSensor) and timed(wrapped, CameraTiming(latency=0.1), 0.04) is (
        wrapped
    )


def test_an_exposure_averages_the_ideal_features_over_the_window() -> None:
    inner = _Clock()
    out = _run(
        TimedSensor(inner, CameraTiming(rate=20.0, exposure=0.02, latency=0.01), 0.01),
        0.01,
        12,
        1.0,
    )
    assert len(inner.calls) % EXPOSURE_SAMPLES == 0
    r = out[-1]
    # The window is symmetric around the stamp: the mean of a uniform motion is its middle.
    assert r.stamp is not None and r.s is not None
    assert r.s[1] == pytest.approx(r.stamp) and r.s[0] == pytest.approx(r.stamp)


def test_reset_forgets_the_frames() -> None:
    inner = _Clock()
    sensor = TimedSensor(inner, CameraTiming(rate=10.0, latency=0.05), 0.01)
    _run(sensor, 0.01, 30)
    sensor.reset()
    assert _run(sensor, 0.01, 1)[0].stamp == pytest.approx(-0.1)
    assert inner.resets == 2


class _NoExposure:
    def reset(self) -> None: ...

    def read(self, task: Any, scene: Any, bMc: Any, t: float) -> SensorReading:
        return SensorReading(np.zeros(1), ())


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"rate": float("nan")}, "rate"),
        ({"rate": -30.0}, "rate"),
        ({"rate": 2e4}, "rate"),
        ({"latency": float("inf")}, "latency"),
        ({"latency": -0.1}, "latency"),
        ({"latency": 0.6}, "latency"),
        ({"exposure": -1e-3}, "exposure"),
        ({"exposure": 0.02, "latency": 0.005}, "latency"),
    ],
)
def test_bad_timing_is_one_error_naming_the_argument(
    kwargs: dict[str, float], argument: str
) -> None:
    with pytest.raises(ConfigurationError) as info:
        CameraTiming(**kwargs)
    assert info.value.argument == argument


def test_an_exposure_the_sensor_cannot_model_or_longer_than_a_frame_is_refused() -> None:
    with pytest.raises(ConfigurationError, match="cannot model an exposure"):
        TimedSensor(_NoExposure(), CameraTiming(exposure=0.004, latency=0.01), 0.01)
    with pytest.raises(ConfigurationError, match="longer than the frame interval"):
        TimedSensor(IdealSensor(), CameraTiming(rate=100.0, exposure=0.02, latency=0.05), 0.01)


class _Live(_Clock):
    live = True  # renders only the present (the MuJoCo camera)


def test_a_live_sensor_is_read_at_the_step_after_the_exposure_and_stamped_then() -> None:
    inner = _Live()
    out = _run(TimedSensor(inner, CameraTiming(rate=10.0, latency=0.1), 0.04), 0.04, 10)
    assert out[0].stamp == pytest.approx(-0.1)  # at rest before the start: its own time
    # Frames due at 0.1, 0.2, 0.3 are taken at the next steps, 0.12, 0.2, 0.32.
    assert inner.calls == pytest.approx([0.0, 0.0, 0.12, 0.2, 0.32])
    assert [r.stamp for r in out][-1] == pytest.approx(0.2)  # 0.32 is not available at 0.36
    with pytest.raises(ConfigurationError, match="cannot model an exposure"):
        TimedSensor(_Live(), CameraTiming(exposure=0.004, latency=0.01), 0.01)


def _held_noise(measured: list[tuple[float | None, np.ndarray]]) -> None:
    """Readings of one frame (same stamp) carry the same noise; each frame has its own."""
    frames: dict[float | None, np.ndarray] = {}
    for stamp, s in measured:
        if stamp in frames:
            assert np.array_equal(frames[stamp], s), "a held frame was given fresh noise"
        frames[stamp] = s
    values = list(frames.values())
    assert len(values) >= 3 and all(not np.array_equal(a, b) for a, b in itertools.pairwise(values))


def test_feature_noise_is_drawn_once_per_frame() -> None:
    noise = FrameNoise(0.01, np.random.default_rng(3))
    sensor = TimedSensor(_Clock(), CameraTiming(rate=25.0), 0.01)
    out = _run(sensor, 0.01, 13)
    noisy = [(r.stamp, noise(r)) for r in out]
    _held_noise(noisy)
    assert all(not np.array_equal(s, r.s) for (_, s), r in zip(noisy, out))  # noised
    fresh = FrameNoise(0.01, np.random.default_rng(3))  # untimed: a new reading every period
    draws = [fresh(SensorReading(np.zeros(2), ())) for _ in range(3)]
    assert not np.array_equal(draws[0], draws[1]) and not np.array_equal(draws[1], draws[2])


def test_the_simulation_holds_a_frame_with_its_noise(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from redservo.control import Controller
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    seen: list[tuple[float | None, np.ndarray]] = []
    step = Controller.step

    def spy(self: Any, q: Any, meas: Any, *args: Any, **kwargs: Any) -> Any:
        seen.append((meas.stamp, np.array(meas.s)))
        return step(self, q, meas, *args, **kwargs)

    monkeypatch.setattr(Controller, "step", spy)
    sets = ["sensor.rate=5.0", "simulation.noise_std=0.001", "simulation.max_iterations=16"]
    build(apply_overrides(load_scenario("panda-4points"), sets)).run()
    assert len(seen) == 16
    _held_noise(seen)


def test_the_servo_loops_simulated_source_holds_a_frame_with_its_noise() -> None:
    from types import SimpleNamespace

    from redservo.hardware.simulated import IdealFeatureSource

    robot = SimpleNamespace(true_pose=lambda: _pose(0.0), t_start=0.0)
    sensor = TimedSensor(_Clock(), CameraTiming(rate=25.0), 0.01)
    source = IdealFeatureSource(None, None, robot, sensor=sensor, noise_std=0.01, seed=1)  # type: ignore[arg-type]
    got = [source.measure(0.01 * k) for k in range(13)]
    _held_noise([(float(k // 4), m.s) for k, m in enumerate(got) if m is not None])  # 25 Hz
