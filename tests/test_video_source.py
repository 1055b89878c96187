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

from redservo.cli import main
from redservo.errors import ConfigurationError
from redservo.experiment import build
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
    with pytest.raises(ConfigurationError, match=r"camera.file: the video .* is 640 x") as e:
        VideoSource(path, small, exp.task, exp.scene, Pose(bMc))
    assert e.value.argument == "camera.file"
    with pytest.raises(ConfigurationError, match=r"camera\.file: no video file"):
        VideoSource(path.with_name("none.avi"), exp.camera, exp.task, exp.scene, Pose(bMc))


@pytest.mark.parametrize(
    ("camera", "what"),
    [
        ('driver = "video"', "key 'camera.file': is needed by camera.driver = 'video'"),
        ('driver = "device"', "publish it on ROS 2 (e.g. the v4l2_camera or usb_cam node)"),
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
