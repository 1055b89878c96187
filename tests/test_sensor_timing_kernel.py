"""The exposure's camera poses in one compiled call (kernels/interp.poses_at) are those of
the per-instant interpolation they replace, bit for bit: before the first pose, between any
two, on a pose's time and after the last (issue 28, image campaigns' speed)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.errors import ShapeError
from redservo.sensors import IdealSensor, SensorReading
from redservo.sensors.timing import CameraTiming, TimedSensor


def _rotation(rng: np.random.Generator, near_pi: bool) -> np.ndarray:
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    angle = np.pi - rng.uniform(0.0, 1e-7) if near_pi else rng.uniform(-np.pi, np.pi)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


def _history(rng: np.random.Generator, m: int) -> list[tuple[float, np.ndarray]]:
    """``m`` poses at increasing times (s): large and tiny rotations, some near π, repeats."""
    t, out = rng.uniform(-0.1, 0.1), []
    for _ in range(m):
        T = np.eye(4)
        kind = rng.integers(0, 4)
        if kind == 0 and out:
            T = out[-1][1].copy()  # the camera at rest
        else:
            T[:3, :3] = _rotation(rng, near_pi=kind == 1)
            T[:3, 3] = rng.uniform(-1.0, 1.0, 3)
        out.append((t, T))
        t += rng.uniform(1e-4, 0.05)
    return out


@pytest.mark.parametrize("seed", range(4))
def test_the_exposures_poses_are_the_per_instant_interpolations(seed: int) -> None:
    rng = np.random.default_rng(seed)
    sensor = TimedSensor(
        IdealSensor(), CameraTiming(rate=30.0, latency=0.066, exposure=0.008), 0.04
    )
    for _ in range(200):
        sensor._poses = _history(rng, int(rng.integers(1, 6)))
        first, last = sensor._poses[0][0], sensor._poses[-1][0]
        t_j = rng.choice([rng.uniform(first - 0.02, last + 0.02), sensor._poses[-1][0] - 0.004])
        samples, stacked = sensor._exposure(float(t_j))
        want = [sensor._pose(t_j + dt) for dt in sensor._offsets]
        assert stacked.shape == (len(want), 4, 4)
        for (T, tw), (T_ref, tw_ref), S in zip(samples, want, stacked):
            assert T.tobytes() == T_ref.tobytes() == S.tobytes()
            assert tw == tw_ref and type(tw) is float


class _Still(IdealSensor):
    def read(self, task: Any, scene: Any, bMc: Any, t: float) -> SensorReading:
        return SensorReading(np.array([t]), ())


def test_a_camera_pose_that_is_not_a_transform_is_refused_when_read() -> None:
    sensor = TimedSensor(_Still(), CameraTiming(rate=30.0, latency=0.066, exposure=0.008), 0.04)
    with pytest.raises(ShapeError, match="bMc"):
        sensor.read(None, None, np.eye(3), 0.0)  # type: ignore[arg-type]
