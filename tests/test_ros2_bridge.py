"""The rate bridge (issue 31): commands published at a higher rate, ramped within the
acceleration limit, a held command dropped after the hold timeout, stop ramps to zero.
Deterministic: the bridge's ticks are driven by hand with fake times."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.errors import ConfigurationError
from redservo.ros2.bridge import RateBridge


class Recorder:
    def __init__(self) -> None:
        self.sent: list[np.ndarray] = []
        self.stops = 0

    def read_joints(self) -> tuple[float, np.ndarray]:
        return 0.0, np.zeros(2)

    def send_velocity(self, qdot: np.ndarray) -> None:
        self.sent.append(np.array(qdot))

    def stop(self) -> None:
        self.stops += 1


def _bridge(now: list[float]) -> tuple[RateBridge, Recorder]:
    rec = Recorder()
    bridge = RateBridge(
        rec,
        2,
        rate=500.0,
        qddot_max=[10.0, 5.0],
        hold_timeout=0.2,
        clock=lambda: now[0],
        start=False,
    )
    return bridge, rec


def test_commands_ramp_within_the_acceleration_limit() -> None:
    now = [0.0]
    bridge, rec = _bridge(now)
    for k in range(300):
        now[0] = k / 500
        if k % 20 == 0:  # the servo loop at 25 Hz
            bridge.send_velocity([1.0, -1.0])
        bridge.tick(now[0])
    sent = np.array(rec.sent)
    steps = np.abs(np.diff(np.vstack([np.zeros(2), sent]), axis=0))
    assert np.all(steps <= np.array([10.0, 5.0]) / 500 + 1e-12)
    assert np.array_equal(sent[-1], [1.0, -1.0])
    assert np.allclose(sent[49], [1.0, -0.5])  # 50 ticks of 0.02 and of 0.01 rad/s


def test_a_held_command_never_outlives_the_hold_timeout() -> None:
    now = [0.0]
    bridge, rec = _bridge(now)
    bridge.send_velocity([0.1, 0.1])
    for k in range(100):  # 0.2 s: within the timeout, the target holds
        bridge.tick(k / 500)
    assert np.array_equal(rec.sent[-1], [0.1, 0.1])
    bridge.tick(0.2 + 1e-6)  # past it: the target is zero, reached within the limit
    assert np.allclose(rec.sent[-1], [0.08, 0.09])
    for k in range(10):
        bridge.tick(0.21 + k / 500)
    assert not np.any(rec.sent[-1])


def test_stop_ramps_to_zero_then_stops_the_robot() -> None:
    now = [0.0]
    bridge, rec = _bridge(now)
    bridge.send_velocity([0.2, 0.0])
    for k in range(20):
        bridge.tick(k / 500)
    bridge.stop()
    sent = np.array(rec.sent)
    assert np.all(np.abs(np.diff(sent, axis=0)) <= np.array([10.0, 5.0]) / 500 + 1e-12)
    assert not np.any(sent[-1]) and rec.stops == 1


@pytest.mark.parametrize(
    ("kw", "arg"),
    [
        ({"rate": 0.5}, "publish_rate"),
        ({"hold_timeout": 0.0}, "hold_timeout"),
        ({"qddot_max": [1.0, 0.0]}, "qddot_max"),
    ],
)
def test_bad_settings_are_one_error_naming_the_argument(kw: dict, arg: str) -> None:
    opts = {"rate": 500.0, "qddot_max": [1.0, 1.0], "hold_timeout": 0.2, **kw}
    with pytest.raises(ConfigurationError) as err:
        RateBridge(Recorder(), 2, start=False, **opts)
    assert err.value.argument == arg
