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
CAMERA = f"/camera_{os.getpid()}"  # topics of this test process only, whoever shares the domain
TOPIC = f"{CAMERA}/image_raw"


def publish(tmp_path: Path, frames: np.ndarray, *args: str, **arrays: Any) -> Any:
    """Start tests/ros2_image_peer.py publishing ``frames``; return (process, its output)."""
    npz, out = tmp_path / "frames.npz", tmp_path / "peer.json"
    np.savez(npz, frames=frames, **arrays)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    cmd = [sys.executable, str(ROOT / "tests" / "ros2_image_peer.py"), str(DOMAIN)]
    return subprocess.Popen([*cmd, str(npz), str(out), "--camera", CAMERA, *args], env=env), out


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


class Pose:
    """The camera pose the tracker is given (the model's at the measured joints)."""

    def __init__(self, bMc: np.ndarray) -> None:
        self.bMc = bMc

    def true_pose(self) -> np.ndarray:
        return self.bMc


def test_an_apriltag_is_measured_through_the_ros_camera(node: Ros2Node, tmp_path: Path) -> None:
    pytest.importorskip("cv2")
    from redservo.experiment.build import build
    from redservo.ros2.image_source import FrameSensor, wait_for_camera
    from redservo.scenario import load_scenario
    from redservo.vision.render import Renderer

    exp = build(load_scenario("afma6-tag-2half-d"))
    bMc = exp.robot.fkine(exp.q0)
    gray = Renderer(exp.camera).render(exp.scene, bMc)  # the tag, as a camera sees it
    cam = exp.camera
    proc, _ = publish(
        tmp_path,
        np.repeat(gray[None, :, :, None], 3, axis=3),  # rgb8
        *("--rate", "20", "--passes", "600", "--info"),
        camera=[cam.px, cam.py, cam.u0, cam.v0, cam.width, cam.height],
    )
    try:
        camera = wait_for_camera(node, f"{CAMERA}/camera_info", 30.0)
        assert camera == cam  # intrinsics through CameraInfo
        source = Ros2ImageSource(node, TOPIC, camera, exp.task, exp.scene, Pose(bMc), EpochStamps())
        try:
            meas = source.first_measurement(30.0)
        finally:
            source.close()
    finally:
        proc.kill()
        proc.wait(timeout=30)
    here = FrameSensor(cam)  # the same detection on the same pixels, in this process
    here.renderer.frame = gray  # type: ignore[attr-defined]
    ref = here.read(exp.task, exp.scene, bMc, 0.0)
    assert ref.s is not None
    np.testing.assert_array_equal(meas.s, ref.s)  # corner (x, y), log depth, θu: all 6
    truth, _ = exp.task.measure(exp.scene, bMc, 0.0)
    np.testing.assert_allclose(meas.s, truth, atol=0.02)  # and it is the tag's true pose
