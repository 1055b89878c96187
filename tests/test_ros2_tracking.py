"""Tracking over a ROS 2 camera (issue 31) on real DDS on the loopback: another process
publishes the frames; decoding and detection run off the loop's thread (a slow frame never
delays ``measure``), the measurement carries the frame's stamp; AprilTags seen through the
``Image`` source."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

from redservo.camera import Camera
from redservo.hardware import FeatureMeasurement
from redservo.ros2.image_source import Ros2ImageSource
from redservo.ros2.messages import Image, Time
from redservo.ros2.stamps import EpochStamps
from redservo.ros2.transport import Ros2Node

ROOT = Path(__file__).resolve().parents[1]
DOMAIN = 200 + os.getpid() % 30  # 200-229: no other ros2 test file uses it
TOPIC = "/camera/image_raw"


def publish(tmp_path: Path, frames: np.ndarray, *args: str, **arrays: Any) -> Any:
    """Start tests/ros2_image_peer.py publishing ``frames``; return (process, its output)."""
    npz, out = tmp_path / "frames.npz", tmp_path / "peer.json"
    np.savez(npz, frames=frames, **arrays)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    cmd = [sys.executable, str(ROOT / "tests" / "ros2_image_peer.py"), str(DOMAIN)]
    return subprocess.Popen([*cmd, str(npz), str(out), *args], env=env), out


def until(condition: Any, what: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.01)


@pytest.fixture(scope="module")
def node() -> Ros2Node:
    return Ros2Node(DOMAIN)


class SlowSource(Ros2ImageSource):
    """Its tracker stops at each frame until ``gate`` opens (a frame that takes forever)."""

    def __init__(self, *args: Any) -> None:
        self.gate = threading.Event()
        self.stamps_seen: list[Time] = []
        super().__init__(*args)

    def _track(self, msg: Image) -> FeatureMeasurement | None:
        self.stamps_seen.append(msg.header.stamp)
        assert self.gate.wait(120.0)
        t = self.stamps.to_loop(msg.header.stamp)
        return FeatureMeasurement(np.zeros(2), (np.ones(1),), t)


def test_a_slow_frame_never_delays_the_loop_and_the_newest_frame_wins(
    node: Ros2Node, tmp_path: Path
) -> None:
    proc, out = publish(tmp_path, np.zeros((8, 4, 6, 3), np.uint8), "--rate", "50", "--wait-reader")
    cam = Camera(5.0, 5.0, 3.0, 2.0, 6, 4)
    source = SlowSource(node, TOPIC, cam, None, None, None, EpochStamps())
    try:
        until(source.worker.busy.is_set, "the tracker to start on the first frame")
        # the tracker is stuck on a frame: the loop's call returns at once, with nothing
        assert source.measure(0.0) is None and not source.gate.is_set()
        assert proc.wait(timeout=60) == 0  # every frame published meanwhile
        source.gate.set()
        until(lambda: source.frames == 2, "the newest frame to be measured")
        published = [Time(s, ns) for s, ns in json.loads(out.read_text())["stamps"]]
        assert source.stamps_seen == [published[0], published[-1]]  # the newest one, not a queue
        assert source.skipped >= 1  # the frames in between are counted, not lost silently
        meas = source.measure(0.0)
        assert meas is not None and meas.t_measured == source.stamps.to_loop(published[-1])
    finally:
        source.gate.set()
        source.close()
    assert not source.worker.alive
