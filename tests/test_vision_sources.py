"""Real input (image folders, video files) and the GIF/MP4 writer, on sequences the tests make."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from redservo.errors import ConfigurationError, ShapeError
from redservo.features import PointFeature, SphereFeature
from redservo.scene import PointSet, Scene, Sphere, Static
from redservo.spatial import make_transform, rotvec_to_matrix
from redservo.task import TaskTerm, VisualTask

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.vision import ImageSensor, frames, track_dots, write_video  # noqa: E402
from redservo.vision.__main__ import main  # noqa: E402
from redservo.vision.render import Renderer, RenderOptions  # noqa: E402

DOTS = np.array(
    [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]
)
N_FRAMES = 12


def _sequence() -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Frames of four dots turning and sliding, and their true pixel positions."""
    r = Renderer(options=RenderOptions(noise_px=1.0, blur_px=0.6, seed=5))
    images, truth = [], []
    for k in range(N_FRAMES):
        T = make_transform(rotvec_to_matrix([0.05, 0.0, 0.08 * k]), [0.004 * k, -0.002 * k, 0.8])
        images.append(r.render(Scene([PointSet("t", DOTS, trajectory=Static(T))]), np.eye(4)))
        P = DOTS @ T[:3, :3].T + T[:3, 3]
        truth.append(r.optics.to_pixel(P[:, :2] / P[:, 2:]))
    return images, truth


def _order(truth0: np.ndarray) -> np.ndarray:
    """The order track_dots gives the first frame's dots (rows of 10 px, then u)."""
    return np.lexsort((truth0[:, 0], np.floor(truth0[:, 1] / 10.0)))


def test_image_folder(tmp_path: Path) -> None:
    images, truth = _sequence()
    for k, img in enumerate(images):
        cv2.imwrite(str(tmp_path / f"frame_{k:03d}.png"), img)
    (tmp_path / "notes.txt").write_text("not an image")
    got = track_dots(tmp_path, 4, threshold=200.0)
    assert len(got) == N_FRAMES
    order = _order(truth[0])
    for fr, tr in zip(got, truth):
        assert fr.detected.all() and fr.reason == ""
        assert np.abs(fr.uv - tr[order]).max() < 0.1  # same order on every frame
        assert fr.xy == pytest.approx((fr.uv - [320.0, 240.0]) / 600.0)
    assert len(list(frames(tmp_path, max_frames=3))) == 3


def test_video_file(tmp_path: Path) -> None:
    images, truth = _sequence()
    path = tmp_path / "dots.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (640, 480), False)
    if not writer.isOpened():
        pytest.skip("this OpenCV build cannot write MJPG/avi")
    for img in images:
        writer.write(img)
    writer.release()
    got = track_dots(str(path), threshold="otsu", initial_uv=truth[0])
    assert len(got) == N_FRAMES
    for fr, tr in zip(got, truth):
        assert fr.detected.all()
        assert np.abs(fr.uv - tr).max() < 0.5  # JPEG-compressed frames
    # An opened capture and a list of frames are sources too.
    assert len(list(frames(cv2.VideoCapture(str(path)), max_frames=2))) == 2
    assert len(track_dots(images[:3], 4, threshold=200.0)) == 3


def test_waiting_for_dots_and_lost_dots() -> None:
    images, _ = _sequence()
    blank = np.full_like(images[0], 40)
    got = track_dots([blank, *images[:3], blank, blank], 4, threshold=200.0, max_lost_frames=1)
    assert "waiting" in got[0].reason and np.isnan(got[0].uv).all()
    assert got[1].detected.all()
    assert "found 0 blob(s), expected 4" in got[4].reason and not got[4].detected.any()
    assert "feature_lost" in got[5].reason


def test_bad_sources() -> None:
    with pytest.raises(ConfigurationError, match="no such file or folder"):
        list(frames("/nonexistent/place"))
    with pytest.raises(ConfigurationError, match="cannot open"):
        list(frames(Path(__file__)))  # a file that is not a video


def test_empty_folder(tmp_path: Path) -> None:
    with pytest.raises(ConfigurationError, match="no image files"):
        list(frames(tmp_path))


def test_cli_on_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    images, _ = _sequence()
    for k, img in enumerate(images[:4]):
        cv2.imwrite(str(tmp_path / f"{k}.png"), img)
    gif = tmp_path / "out" / "dots.gif"
    assert main([str(tmp_path), "--dots", "4", "--threshold", "200", "--gif", str(gif)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("frame 0: ") and len(out[0].split()) == 2 + 8
    assert gif.exists()
    assert main(["/nonexistent/place"]) == 2


def test_write_gif_and_mp4(tmp_path: Path) -> None:
    scene = Scene(
        [
            PointSet("target", DOTS, trajectory=Static(make_transform(t=[0.0, 0.0, 0.8]))),
            Sphere("ball", 0.05, trajectory=Static(make_transform(t=[-0.2, 0.15, 1.0]))),
        ]
    )
    desired = {"target": make_transform(t=[0, 0, 0.6]), "ball": make_transform(t=[0, 0, 0.7])}
    terms = [TaskTerm(PointFeature(p), "target") for p in DOTS]
    terms.append(TaskTerm(SphereFeature(0.05), "ball"))
    task = VisualTask.from_desired_poses(terms, desired)
    sensor = ImageSensor()
    readings = [sensor.read(task, scene, make_transform(t=[0.01 * k, 0, 0]), 0.0) for k in range(5)]
    imgs = [r.image for r in readings]
    dets = [r.s for r in readings]
    errs = [float(np.linalg.norm(task.error(s))) for s in dets if s is not None]
    gif = write_video(
        tmp_path / "run.gif", imgs, task=task, detected=dets, desired=task.s_star, errors=errs
    )
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames == 5 and im.size == (640 + 320, 480)
    try:
        mp4 = write_video(tmp_path / "run.mp4", imgs, task=task, detected=dets, errors=errs)
        assert mp4.stat().st_size > 0
    except ConfigurationError as exc:
        assert ".gif" in str(exc)
    with pytest.raises(ConfigurationError, match=r"\.gif or \.mp4"):
        write_video(tmp_path / "run.webm", imgs)
    with pytest.raises(ShapeError, match="one entry per frame"):
        write_video(tmp_path / "run.gif", imgs, errors=errs[:2])
    with pytest.raises(ConfigurationError, match="at least one frame"):
        write_video(tmp_path / "run.gif", [])
