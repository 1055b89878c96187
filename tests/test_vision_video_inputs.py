"""Damaged and odd inputs of ``python -m redservo.vision`` and the frame sources (issue 32): a
truncated video is reported against its container's count, a damaged frame keeps its number,
a file that is not an image or a video is one error, options that do nothing are refused."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from redservo.errors import ConfigurationError

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.vision.__main__ import PROG, main  # noqa: E402
from redservo.vision.capture import VideoWarning  # noqa: E402
from redservo.vision.sources import frames, numbered_frames, track_dots  # noqa: E402

N = 30


def _video(path: Path) -> Path:
    """An MJPG video of ``N`` frames of two dots, the first moving right by 2 px a frame."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (160, 120), False)
    if not writer.isOpened():
        pytest.skip("this OpenCV build cannot write MJPG/avi")
    for k in range(N):
        img = np.full((120, 160), 30, np.uint8)
        cv2.circle(img, (20 + 2 * k, 40), 4, 255, -1)
        cv2.circle(img, (80, 90), 4, 255, -1)
        writer.write(img)
    writer.release()
    return path


def _damage_frame(path: Path, k: int) -> Path:
    """Zero the first 200 bytes of frame ``k``'s JPEG (its markers and tables)."""
    data = bytearray(path.read_bytes())
    starts = [i for i in range(len(data) - 1) if data[i] == 0xFF and data[i + 1] == 0xD8]
    assert len(starts) == N
    data[starts[k] : starts[k] + 200] = bytes(200)
    path.write_bytes(bytes(data))
    return path


def _numbers(source: Path) -> tuple[list[int], list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ks = [k for k, _ in numbered_frames(str(source))]
    return ks, [str(w.message) for w in caught if issubclass(w.category, VideoWarning)]


def test_a_truncated_video_says_how_many_frames_it_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _video(tmp_path / "clip.avi")
    assert _numbers(path) == (list(range(N)), [])  # a whole video: no warning
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    ks, said = _numbers(path)
    assert 0 < len(ks) < N and ks == list(range(len(ks)))
    assert said == [
        f"video file {path}: read {len(ks)} of the {N} frames its container announces "
        "(a truncated or damaged file?)"
    ]
    with warnings.catch_warnings(record=True) as caught:  # max_frames within what is there
        warnings.simplefilter("always")
        assert len(list(frames(str(path), max_frames=3))) == 3
    assert not caught
    assert main([str(path), "--dots", "2"]) == 0
    captured = capsys.readouterr()
    assert captured.err == (
        f"{PROG}: warning: video file {path}: read {len(ks)} of the {N} frames its container "
        "announces (a truncated or damaged file?)\n"
    )
    assert len(captured.out.splitlines()) == len(ks)


def test_a_damaged_frame_keeps_its_number(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _damage_frame(_video(tmp_path / "clip.avi"), 10)
    ks, said = _numbers(path)
    assert ks == [k for k in range(N) if k != 10]
    assert said == [
        f"video file {path}: 1 frame(s) could not be decoded and were skipped, keeping the "
        "numbers of the others: 10"
    ]
    with pytest.warns(VideoWarning, match="could not be decoded"):
        got = track_dots(str(path), 2, threshold=128.0)
    assert [fr.frame for fr in got] == list(range(N))
    assert got[10].reason.startswith("damaged") and np.isnan(got[10].uv).all()
    for k in (9, 11, 29):  # the moving dot is where frame k put it: no shift after the gap
        assert got[k].detected.all()
        assert np.abs(got[k].uv[:, 0] - [20.5 + 2 * k, 80.5]).min() < 1.0, got[k].uv
    gif = tmp_path / "dots.gif"
    assert main([str(path), "--dots", "2", "--threshold", "128", "--gif", str(gif)]) == 0
    captured = capsys.readouterr()
    lines = captured.out.splitlines()
    assert lines[10].startswith("frame 10: ") and "[damaged" in lines[10]
    assert lines[11].startswith("frame 11: ") and "could not be decoded" in captured.err
    assert gif.exists()
    assert main([str(path), "--tags", "36h11", "--frames", "12"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert (
        lines[10] == "frame 10: damaged (could not be decoded)" and lines[11] == "frame 11: no tag"
    )


def test_a_video_with_no_decodable_frame_is_an_error(tmp_path: Path) -> None:
    path = _video(tmp_path / "clip.avi")
    data = bytearray(path.read_bytes())
    starts = [i for i in range(len(data) - 1) if data[i] == 0xFF and data[i + 1] == 0xD8]
    for s in starts:
        data[s : s + 200] = bytes(200)
    path.write_bytes(bytes(data))
    with pytest.raises(ConfigurationError, match="not one frame could be decoded"):
        list(frames(str(path)))


@pytest.mark.parametrize("tags", [False, True])
@pytest.mark.parametrize("name", ["notes.png", "notes.jpg", "notes.avi"])
def test_a_file_that_is_no_image_is_one_error(
    tmp_path: Path, name: str, tags: bool, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / name
    path.write_text("hello, not an image\n" * 10)
    assert main([str(path), *(["--tags", "36h11"] if tags else [])]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "Traceback" not in captured.err
    assert captured.err.count("\n") == 1 and str(path) in captured.err


def test_one_image_file_is_a_source(tmp_path: Path) -> None:
    img = np.full((120, 160), 30, np.uint8)
    cv2.imwrite(str(tmp_path / "one.png"), img)
    got = list(frames(str(tmp_path / "one.png")))
    assert len(got) == 1 and np.array_equal(got[0], img)


@pytest.mark.parametrize(
    "extra", [["--camera", "cam.yaml"], ["--tag-size", "0.05"]], ids=["camera", "tag-size"]
)
def test_tag_options_without_tags_are_refused(
    tmp_path: Path, extra: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    path = _video(tmp_path / "clip.avi")
    assert main([str(path), *extra]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1
    assert captured.err.startswith(f"{PROG}: error: {extra[0]} goes with --tags")


def test_tag_feature_source_reads_image_paths_and_refuses_junk(tmp_path: Path) -> None:
    from redservo.camera import Camera
    from redservo.features import PointFeature
    from redservo.scene import Scene, Static, Tag
    from redservo.spatial import make_transform
    from redservo.task import TaskTerm, VisualTask
    from redservo.vision.render import Renderer
    from redservo.vision.tag_source import TagFeatureSource

    cam = Camera(px=300.0, py=300.0, u0=160.0, v0=120.0, width=320, height=240)
    tag = Tag("tag", size=0.1, tag_id=7)
    pose = make_transform(t=[0.0, 0.0, 0.3], rotvec=[np.pi + 0.1, 0.05, 0.2])
    img = Renderer(cam).render(
        Scene([Tag("tag", size=0.1, tag_id=7, trajectory=Static(pose))]), np.eye(4)
    )
    cv2.imwrite(str(tmp_path / "a.png"), img)
    task = VisualTask.from_desired_poses(
        [TaskTerm(PointFeature(p), "tag") for p in tag.points], {"tag": pose}
    )
    src = TagFeatureSource(task, {"tag": tag}, [str(tmp_path / "a.png")], cam)
    m = src.measure(0.0)
    assert m is not None and m.s.shape == (8,)
    for junk, what in (([tmp_path / "none.png"], "none.png"), ([np.zeros(5)], "source[0]")):
        bad = TagFeatureSource(task, {"tag": tag}, junk, cam)
        with pytest.raises(ConfigurationError, match=what.replace("[", r"\[")):
            bad.measure(0.0)


def test_tag_feature_source_keeps_the_number_of_a_damaged_frame(tmp_path: Path) -> None:
    from redservo.camera import Camera
    from redservo.features import PointFeature
    from redservo.scene import Tag
    from redservo.task import TaskTerm, VisualTask
    from redservo.vision import TagFeatureSource

    tag = Tag("tag", size=0.1, tag_id=7)
    task = VisualTask([TaskTerm(PointFeature(tag.points[0]), "tag")], np.zeros(2))
    path = _damage_frame(_video(tmp_path / "clip.avi"), 10)
    src = TagFeatureSource(task, {"tag": tag}, str(path), Camera())
    reasons = []
    with pytest.warns(VideoWarning):
        for _ in range(N + 1):
            assert src.measure(0.0) is None  # no tag in these frames
            reasons.append(src.reason)
    assert reasons[10] == "frame 10: damaged (could not be decoded)"
    assert reasons[9].startswith("frame 9, term 0") and reasons[11].startswith("frame 11, term 0")
    assert reasons[N] == "the source has no more frames"
