"""The ``video`` camera of ``redservo servo`` (issue 31): a file played at its frame rate
through OpenCV, measured off the loop's thread, stamped at each frame's time; its errors."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("cv2")

import cv2

from redservo.cli.entry import main
from redservo.errors import ConfigurationError
from redservo.experiment.build import build
from redservo.hardware.video import VideoSource
from redservo.scenario import load_scenario
from redservo.vision.render import Renderer

FPS = 50.0


class Pose:
    def __init__(self, bMc: np.ndarray) -> None:
        self.bMc = bMc

    def true_pose(self) -> np.ndarray:
        return self.bMc


@pytest.fixture(scope="module")
def tag_video(tmp_path_factory: Any) -> tuple[Any, Path, np.ndarray]:
    """afma6-tag-2half-d's tag filmed from q0: 12 frames at 50 fps (lossless FFV1)."""
    exp = build(load_scenario("afma6-tag-2half-d"))
    bMc = exp.robot.fkine(exp.q0)
    gray = Renderer(exp.camera).render(exp.scene, bMc)
    path = tmp_path_factory.mktemp("video") / "tag.avi"
    size = (exp.camera.width, exp.camera.height)
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), FPS, size)
    assert out.isOpened()
    for _ in range(12):
        out.write(cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR))
    out.release()
    return exp, path, bMc


def test_a_tag_video_plays_at_its_rate_and_is_measured(tag_video: Any) -> None:
    exp, path, bMc = tag_video
    source = VideoSource(path, exp.camera, exp.task, exp.scene, Pose(bMc))
    stamps = []
    try:
        first = source.first_measurement(30.0)
        assert source.fps == FPS
        while not source.ended:
            meas = source.measure(0.0)
            if meas is not None and (not stamps or meas.t_measured != stamps[-1]):
                stamps.append(meas.t_measured)
            source.sleep(0.002)
    finally:
        source.close()
    truth, _ = exp.task.measure(exp.scene, bMc, 0.0)
    np.testing.assert_allclose(first.s, truth, atol=0.02)  # the tag's corner, depth, θu
    assert source.frames + source.skipped == 12  # every frame measured or counted as skipped
    steps = np.diff(stamps) * FPS  # stamps at the frames' times: t0 + i / fps
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    assert np.all(steps > 0.5)  # newer frames only


def test_a_video_of_another_size_is_one_error_naming_the_key(tag_video: Any) -> None:
    exp, path, bMc = tag_video
    small = dataclasses.replace(exp.camera, width=exp.camera.width // 2)
    with pytest.raises(ConfigurationError, match=r"camera.file: the video .* delivers 640 x") as e:
        VideoSource(path, small, exp.task, exp.scene, Pose(bMc))
    assert e.value.argument == "camera.file"
    with pytest.raises(ConfigurationError, match=r"camera\.file: no video file"):
        VideoSource(path.with_name("none.avi"), exp.camera, exp.task, exp.scene, Pose(bMc))


@pytest.mark.parametrize(
    ("camera", "what"),
    [
        ('driver = "video"', "key 'camera.file': is needed by camera.driver = 'video'"),
        ('driver = "device"\ndevice = -1', "key 'camera.device': must be a device index >= 0"),
        ('driver = "video"\nfile = 3', "key 'camera.file': must be the path of a video file"),
    ],
)
def test_camera_driver_errors_are_one_line(
    tmp_path: Path, capsys: Any, camera: str, what: str
) -> None:
    f = tmp_path / "hw.toml"
    f.write_text(f'[robot]\ndriver = "mujoco"\n[camera]\n{camera}\n')
    assert main(["servo", "panda-4points", "--hardware", str(f), "--yes"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and what in err, err


def test_a_live_device_is_read_as_it_delivers_and_stamped_less_its_latency(
    tag_video: Any,
) -> None:
    """The ``device`` camera on OpenCV's own capture (of the recorded tag, as a device would
    deliver frames): each frame measured off the loop's thread, stamped at delivery less the
    declared latency, on an injected clock."""
    from redservo.hardware.device import DeviceSource, check_size

    exp, path, bMc = tag_video
    now = [100.0]

    def clock() -> float:
        now[0] += 0.01
        return now[0]

    cap = check_size(cv2.VideoCapture(str(path)), exp.camera, "the tag video", "camera.device")
    source = DeviceSource(
        cap, exp.camera, exp.task, exp.scene, Pose(bMc), latency=0.05, clock=clock
    )
    try:
        first = source.first_measurement(30.0)
        while not source.ended:
            source.sleep(0.002)
    finally:
        source.close()
    truth, _ = exp.task.measure(exp.scene, bMc, 0.0)
    np.testing.assert_allclose(first.s, truth, atol=0.02)
    assert source.frames == 12 and source.skipped == 0
    last = source.measure(0.0)
    assert last is not None and last.t_measured < now[0] - 0.05 + 1e-9  # delivery less latency


def test_a_device_of_another_size_or_absent_is_one_error_naming_the_key(tag_video: Any) -> None:
    from redservo.hardware.device import DeviceSource, check_size, open_device

    exp, path, bMc = tag_video
    small = dataclasses.replace(exp.camera, width=exp.camera.width // 2)
    with pytest.raises(ConfigurationError, match=r"camera.device: the tag video delivers 640 x"):
        check_size(cv2.VideoCapture(str(path)), small, "the tag video", "camera.device")
    with pytest.raises(ConfigurationError, match=r"camera\.device: OpenCV cannot open") as e:
        open_device(str(path.with_name("no-such-camera")), exp.camera)
    assert e.value.argument == "camera.device"
    with pytest.raises(ConfigurationError, match=r"camera\.latency"):
        DeviceSource(None, exp.camera, exp.task, exp.scene, Pose(bMc), latency=-1.0)
