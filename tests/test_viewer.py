"""3-D viewer and animation: link frames, joint axes, the camera image, a video, and the page
in a real headless browser (Chromium from the system's packages; skipped without it)."""

from __future__ import annotations

import base64
import itertools
import json
import os
import shutil
import socket
import subprocess
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pytest

from redservo import load_run
from redservo.cli.entry import main
from redservo.robots import Afma6, Humanoid9, Panda
from redservo.scenario import load_scenario, parse_scenario

CHROMIUM = os.environ.get("REDSERVO_CHROMIUM", "/usr/bin/chromium")
T = TypeVar("T")


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
    from redservo.experiment.build import build

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
    from redservo.plots.style import role_rgb

    orange = np.all(np.abs(img.astype(int) - role_rgb("desired")) < 30, axis=2)
    blue = np.all(np.abs(img.astype(int) - role_rgb("current")) < 30, axis=2)
    assert orange.sum() > 20 and blue.sum() > 20  # desired crosses, current circles


def test_animate_writes_a_gif(
    panda_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A GIF large enough to read (1280 px wide, fonts of 10 pt and more), with progress."""
    pytest.importorskip("matplotlib")
    pytest.importorskip("PIL")
    from PIL import Image

    from redservo.viewer.animate import _FONT

    out = tmp_path / "run.gif"
    assert main(["animate", str(panda_run), "--out", str(out), "--frames", "3"]) == 0
    gif = Image.open(out)
    assert gif.n_frames == 3 and gif.size == (1280, 560)
    assert min(_FONT.values()) >= 10
    err = capsys.readouterr().err
    assert "animate: drawing 3 frames" in err and "animate: frame 3 of 3" in err
    assert f"animate: writing {out}" in err
    assert main(["animate", str(panda_run), "--out", str(tmp_path / "x.avi")]) == 2


def test_view_refuses_a_campaign_directory(tmp_path: Path) -> None:
    (tmp_path / "samples.csv").write_text("sample\n")
    assert main(["view", str(tmp_path)]) == 2


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _DevTools:
    """Just enough of the Chrome DevTools protocol (over a WebSocket) to wait and screenshot."""

    def __init__(self, ws_url: str) -> None:
        from websockets.sync.client import connect

        self.ws = connect(ws_url, max_size=None, open_timeout=60)
        self.ids = itertools.count(1)

    def call(self, method: str, timeout: float, **params: object) -> dict[str, Any]:
        msg_id = next(self.ids)
        self.ws.send(json.dumps({"id": msg_id, "method": method, "params": params}))
        deadline = time.monotonic() + timeout
        while True:
            reply = json.loads(self.ws.recv(timeout=max(deadline - time.monotonic(), 0.01)))
            if reply.get("id") == msg_id:  # events in between are ignored
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return dict(reply["result"])

    def close(self) -> None:
        self.ws.close()


def _wait_for(what: str, deadline: float, probe: Callable[[], T | None]) -> T:
    """Poll ``probe`` until it returns a value other than None; fail at ``deadline``."""
    while True:
        value = probe()
        if value is not None:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"gave up waiting for {what}")
        time.sleep(0.2)  # a polling interval, not a synchronisation


def _page_target(port: int) -> str | None:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
            targets = json.load(r)
    except OSError:
        return None
    pages = [t for t in targets if t.get("type") == "page" and "webSocketDebuggerUrl" in t]
    return str(pages[0]["webSocketDebuggerUrl"]) if pages else None


def _screenshot_when_drawn(url: str, profile: Path, budget_s: float) -> bytes:
    """Open ``url`` in headless Chromium, wait until the page reports that it has drawn the
    scene (the viewer's DRAWN_ID element), and return a PNG screenshot of the page.

    Nothing is timed: the page's own flag is awaited (up to ``budget_s`` seconds in all, for
    a machine whose cores another test suite keeps busy)."""
    from redservo.viewer.server import DRAWN_ID

    deadline = time.monotonic() + budget_s
    proc = subprocess.Popen(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-background-timer-throttling",
            "--disable-renderer-backgrounding",
            "--remote-debugging-port=0",
            f"--user-data-dir={profile}",
            "--window-size=1024,768",
            url,
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    tools: _DevTools | None = None
    try:
        active = profile / "DevToolsActivePort"  # written by Chromium once it listens

        def port() -> int | None:
            if proc.poll() is not None:
                raise AssertionError(f"Chromium exited with code {proc.returncode}")
            text = active.read_text() if active.exists() else ""
            return int(text.split()[0]) if len(text.split()) >= 2 else None

        debug_port = _wait_for("Chromium's DevTools port", deadline, port)
        ws_url = _wait_for("the page's target", deadline, lambda: _page_target(debug_port))
        tools = devtools = _DevTools(ws_url)
        # The viewport, whatever this Chromium makes of --window-size (its frame is not shown).
        left = max(deadline - time.monotonic(), 30.0)
        tools.call(
            "Emulation.setDeviceMetricsOverride",
            left,
            width=1024,
            height=768,
            deviceScaleFactor=1,
            mobile=False,
        )
        check = f"document.getElementById({DRAWN_ID!r})?.dataset.drawn === 'true'"

        def drawn() -> bool | None:
            left = max(deadline - time.monotonic(), 1.0)
            res = devtools.call("Runtime.evaluate", left, expression=check)
            return True if res["result"] == {"type": "boolean", "value": True} else None

        _wait_for(f"the page to set #{DRAWN_ID}", deadline, drawn)
        left = max(deadline - time.monotonic(), 30.0)
        shot = tools.call("Page.captureScreenshot", left, format="png")
        return base64.b64decode(str(shot["data"]))
    finally:
        if tools is not None:
            tools.close()
        proc.terminate()
        try:
            proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def test_viewer_page_shows_the_robot_in_a_headless_browser(panda_run: Path, tmp_path: Path) -> None:
    """Serve the Panda run, wait for the page's own "drawn" flag in headless Chromium, take a
    screenshot and check that it is not blank and shows the robot's links (their purple)."""
    pytest.importorskip("viser", reason="the viewer needs viser (redservo[viewer])")
    pytest.importorskip("websockets", reason="viser's dependency, used to drive Chromium")
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        pytest.skip(f"no Chromium at {CHROMIUM} (apt-get install chromium; make test does)")
    from PIL import Image

    from redservo.viewer.playback import Playback
    from redservo.viewer.server import LINK_COLOR, serve

    session = serve(Playback(load_run(panda_run)), port=_free_port(), block=False)
    try:
        png = _screenshot_when_drawn(session.url, tmp_path / "profile", budget_s=240.0)
    finally:
        session.stop()
    shot = tmp_path / "viewer.png"
    shot.write_bytes(png)
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    keep = os.environ.get("REDSERVO_KEEP_SCREENSHOT")
    if keep:
        shutil.copy(shot, keep)
    assert img.shape == (768, 1024, 3)
    assert float(img.std()) > 5.0  # not a blank page
    # The links' purple (LINK_COLOR): red and blue well above green (hue, not exact colour:
    # lines are anti-aliased and shaded).
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    assert LINK_COLOR[0] - LINK_COLOR[1] > 25 and LINK_COLOR[2] - LINK_COLOR[1] > 25
    robot = (r - g > 25) & (b - g > 25)
    assert int(robot.sum()) > 200, f"only {int(robot.sum())} robot-coloured pixels"


def test_the_drawn_flag_needs_the_links_purple_in_the_render() -> None:
    """The page is marked drawn only from a render that shows the robot's links."""
    pytest.importorskip("viser", reason="the viewer needs viser (redservo[viewer])")
    from redservo.viewer.server import LINK_COLOR, _shows_links

    img = np.full((180, 240, 3), 255, np.uint8)  # an empty white scene
    assert not _shows_links(img)
    img[50:55, 40:80] = LINK_COLOR  # 200 pixels of a link
    assert _shows_links(img)
    assert _shows_links(np.dstack([img, np.full(img.shape[:2], 255, np.uint8)]))  # RGBA
    img[50:55, 40:80] = (230, 159, 0)  # the targets' orange is not the robot
    assert not _shows_links(img)


_MESH_URDF_TAIL = """
  <joint name="extra_fixed" type="fixed">
    <parent link="panda_link0"/>
    <child link="extra_link"/>
    <origin xyz="0.2 0 0" rpy="0 0 0"/>
  </joint>
  <link name="extra_link">
    <visual>
      <origin xyz="0 0 0.5" rpy="0 0 1.5707963267948966"/>
      <geometry><mesh filename="package://myrobot/meshes/part.stl" scale="2 2 2"/></geometry>
      <material name="red"><color rgba="1 0 0 1"/></material>
    </visual>
    <visual>
      <geometry><mesh filename="../meshes/part.obj"/></geometry>
    </visual>
    <visual>
      <geometry><mesh filename="meshes/missing.dae"/></geometry>
    </visual>
  </link>
"""


def _mesh_urdf(root: Path) -> Path:
    """The shipped Panda URDF in ``root/myrobot/urdf/``, its base column an STL file (a 0.12 m
    box), plus a link fixed to the base with an STL (``package://``), an OBJ and a missing DAE."""
    trimesh = pytest.importorskip("trimesh", reason="meshes need trimesh (redservo[viewer])")
    from redservo.robots import shipped_urdf

    pkg = root / "myrobot"
    (pkg / "meshes").mkdir(parents=True)
    (pkg / "urdf").mkdir()
    trimesh.creation.box(extents=(0.12, 0.12, 0.12)).export(pkg / "meshes" / "part.stl")
    trimesh.creation.icosphere(subdivisions=1, radius=0.05).export(pkg / "meshes" / "part.obj")
    text = shipped_urdf("panda").read_text(encoding="utf-8")
    column = '<geometry><cylinder radius="0.06" length="0.333"/></geometry>'
    assert column in text
    text = text.replace(column, '<geometry><mesh filename="../meshes/part.stl"/></geometry>', 1)
    text = text.replace("</robot>", _MESH_URDF_TAIL + "</robot>")
    path = pkg / "urdf" / "robot.urdf"
    path.write_text(text, encoding="utf-8")
    return path


def test_urdf_visuals_load_meshes_and_primitives(tmp_path: Path) -> None:
    from redservo.viewer.meshes import urdf_visuals

    path = _mesh_urdf(tmp_path)
    got = urdf_visuals(path)
    by_link: dict[str, list[Any]] = {}
    for v in got.visuals:
        by_link.setdefault(v.link, []).append(v)
    column = by_link["panda_link0"][0]
    assert column.source.endswith("part.stl") and column.faces.shape == (12, 3)
    assert np.allclose(np.ptp(column.vertices, axis=0), 0.12, atol=1e-6)
    assert column.color == (230, 230, 230)  # the file's named material "white"
    stl, obj = by_link["extra_link"]
    assert np.allclose(np.ptp(stl.vertices, axis=0), 0.24, atol=1e-6)  # scale="2 2 2"
    assert stl.color == (255, 0, 0) and obj.color is None and obj.source.endswith("part.obj")
    assert np.allclose(stl.lMv[:3, 3], [0, 0, 0.5])
    assert np.allclose(stl.lMv[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-12)  # yaw π/2
    assert any(v.source == "cylinder" for v in by_link["panda_link1"])  # primitives built
    assert len(got.notes) == 1 and "1 mesh file(s) not found" in got.notes[0]
    assert "missing.dae" in got.notes[0] and "sticks" in got.notes[0]
    assert not urdf_visuals(path, {"panda_link0"}).notes  # only the links asked for
    assert urdf_visuals(tmp_path / "nope.urdf").notes


def test_viewer_draws_the_urdf_meshes_and_the_objects_as_they_are(tmp_path: Path) -> None:
    """A URDF run is served with its visual meshes placed at bMl · lMv at every frame; the
    objects are a tag (its squares), a sphere, a cylinder (a mesh) and points."""
    pytest.importorskip("viser", reason="the viewer needs viser (redservo[viewer])")
    pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio (redservo[urdf])")
    from redservo.experiment.build import build
    from redservo.viewer.playback import Playback
    from redservo.viewer.server import serve

    urdf = _mesh_urdf(tmp_path)
    sc = load_scenario("panda-urdf-4points")
    data = {**sc.data, "simulation": {"max_iterations": 8}}
    data["robot"] = {**data["robot"], "urdf": str(urdf)}
    data["objects"] = [
        *data["objects"],
        {"name": "ball", "kind": "sphere", "radius": 0.03, "pose": {"translation": [0.5, 0, 0.2]}},
        {
            "name": "pipe",
            "kind": "cylinder",
            "radius": 0.02,
            "pose": {"translation": [0.5, 0.2, 0.2]},
        },
        {"name": "marker", "kind": "tag", "size": 0.08, "pose": {"translation": [0.5, -0.2, 0.2]}},
    ]
    run_dir = tmp_path / "run"
    build(parse_scenario(data, "meshes")).run().save(run_dir)
    pb = Playback(load_run(run_dir))
    session = serve(pb, port=_free_port(), block=False, max_frames=4)
    try:
        surfaces = session.handles["surfaces"]
        kinds = [how[0] for _, how in surfaces]
        assert kinds.count("visual") == 15 + 2  # the Panda's 15 visuals + the STL and OBJ
        assert kinds.count("tag") == 2 and {"sphere", "cylinder", "points"} <= set(kinds)
        assert any("missing.dae" in n for n in session.notes)
        k = session.frames[-1]
        session.show(len(session.frames) - 1)
        fr = pb.frame(k)
        for handle, how in surfaces:
            if how[0] == "visual":
                T = fr.links[how[1]] @ how[2]
                assert np.allclose(handle.position, T[:3, 3], atol=1e-6), how[1]
    finally:
        session.stop()
