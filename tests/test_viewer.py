"""3-D viewer and animation: link frames, joint axes, the camera image, a video, and the page
in a real headless browser (Chromium from the system's packages; skipped without it)."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
from pathlib import Path

import numpy as np
import pytest

from redservo import load_run
from redservo.cli import main
from redservo.robots import Afma6, Humanoid9, Panda
from redservo.scenario import load_scenario, parse_scenario

CHROMIUM = os.environ.get("REDSERVO_CHROMIUM", "/usr/bin/chromium")


@pytest.mark.parametrize("robot", [Panda(), Humanoid9(), Afma6()], ids=lambda r: r.name)
def test_link_poses_end_at_the_end_effector(robot: object) -> None:
    from redservo.robots.base import Robot

    assert isinstance(robot, Robot)
    rng = np.random.default_rng(0)
    q = robot.q_min + rng.uniform(0.2, 0.8, robot.n) * (robot.q_max - robot.q_min)
    poses = robot.link_poses(q)  # type: ignore[attr-defined]
    assert next(iter(poses)) == "base" and list(poses)[-1] == "ee"
    assert np.allclose(poses["ee"], robot.fkine_ee(q))
    assert np.allclose(poses["ee"] @ robot.eMc, robot.fkine(q))
    for T in poses.values():
        assert T.shape == (4, 4) and np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3))


@pytest.fixture(scope="module")
def panda_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short Panda run (its elbow starts near its lower limit), saved with its scenario."""
    from redservo.experiment import build

    out = tmp_path_factory.mktemp("view") / "panda"
    sc = load_scenario("panda-4points")
    sc = parse_scenario({**sc.data, "simulation": {"max_iterations": 60}}, sc.source)
    build(sc).run().save(out)
    return out


def test_joint_axes_follow_the_dh_frames(panda_run: Path) -> None:
    """The viewer's axes (from the Jacobian) are the z axes of the modified-DH frames."""
    from redservo.viewer.playback import Playback

    pb = Playback(load_run(panda_run))
    fr = pb.frame(len(pb) - 1)
    frames = [fr.links[name] for name in pb.joint_names]
    for (p, d, prismatic), T in zip(fr.axes, frames):
        assert not prismatic
        assert abs(float(d @ T[:3, 2])) == pytest.approx(1.0, abs=1e-9)
        assert np.linalg.norm(np.cross(p - T[:3, 3], T[:3, 2])) < 1e-9  # p on the axis
    assert fr.levels[3] > 0.0  # the elbow is inside its band
    assert np.all((fr.levels >= 0) & (fr.levels <= 1))
    assert pb.frames(10)[-1] == len(pb) - 1 and len(pb.frames(10)) <= 10


def test_camera_image_shows_the_features(panda_run: Path) -> None:
    pytest.importorskip("PIL", reason="the camera image needs Pillow (redservo[viewer])")
    from redservo.viewer.image import camera_image
    from redservo.viewer.playback import Playback

    img = camera_image(Playback(load_run(panda_run)), 5, width=320)
    assert img.shape == (240, 320, 3) and img.dtype == np.uint8
    orange = np.all(np.abs(img.astype(int) - (230, 159, 0)) < 30, axis=2)
    blue = np.all(np.abs(img.astype(int) - (86, 180, 233)) < 30, axis=2)
    assert orange.sum() > 20 and blue.sum() > 20  # desired crosses, current circles


def test_animate_writes_a_gif(panda_run: Path, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    pytest.importorskip("PIL")
    from PIL import Image

    out = tmp_path / "run.gif"
    assert main(["animate", str(panda_run), "--out", str(out), "--frames", "3"]) == 0
    gif = Image.open(out)
    assert gif.n_frames == 3 and gif.size[0] > 600
    assert main(["animate", str(panda_run), "--out", str(tmp_path / "x.avi")]) == 2


def test_view_refuses_a_campaign_directory(tmp_path: Path) -> None:
    (tmp_path / "samples.csv").write_text("sample\n")
    assert main(["view", str(tmp_path)]) == 2


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_viewer_page_shows_the_robot_in_a_headless_browser(panda_run: Path, tmp_path: Path) -> None:
    """Serve the Panda run, screenshot the page with headless Chromium, and check that the
    picture is not blank and shows the robot's links (their purple)."""
    pytest.importorskip("viser", reason="the viewer needs viser (redservo[viewer])")
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        pytest.skip(f"no Chromium at {CHROMIUM} (apt-get install chromium; make test does)")
    from PIL import Image

    from redservo.viewer.playback import Playback
    from redservo.viewer.server import LINK_COLOR, serve

    run_dir = panda_run
    port = _free_port()
    session = serve(Playback(load_run(run_dir)), port=port, block=False)
    shot = tmp_path / "viewer.png"
    command = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={tmp_path / 'profile'}",
        f"--screenshot={shot}",
        "--window-size=1024,768",
        "--virtual-time-budget=6000",  # ms of page time: the scene is drawn well before
        session.url,
    ]
    try:
        for attempt in range(2):  # on a loaded machine software WebGL can stall once
            try:
                subprocess.run(command, check=True, capture_output=True, timeout=150)
                break
            except subprocess.TimeoutExpired:
                if attempt:
                    raise
    finally:
        session.stop()
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    keep = os.environ.get("REDSERVO_KEEP_SCREENSHOT")
    if keep:
        shutil.copy(shot, keep)
    assert img.shape == (768, 1024, 3)
    assert float(img.std()) > 5.0  # not a blank page
    # The links' purple (LINK_COLOR): red and blue well above green; the page fades the scene
    # in, so the hue is tested, not the exact colour.
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    assert LINK_COLOR[0] - LINK_COLOR[1] > 25 and LINK_COLOR[2] - LINK_COLOR[1] > 25
    robot = (r - g > 25) & (b - g > 25)
    assert int(robot.sum()) > 200, f"only {int(robot.sum())} robot-coloured pixels"
