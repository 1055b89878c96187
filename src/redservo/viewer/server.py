"""``redservo view PATH``: an interactive 3-D view of a saved run in the web browser (viser).

The page shows, in the robot base frame (metres, the grid is the base's x-y plane): the
robot's links (purple) through its link frames, each joint axis as a short bar coloured by
how close the joint is to its limits (blue: inside its thresholds; orange at the threshold,
CM01 eq. 3; vermillion at the limit), the camera frustum with the camera image on it, the
camera's path, and the target objects as they are (green, the ``target`` colour of every
figure; :mod:`~redservo.viewer.surfaces`); a URDF robot also gets its visual meshes when the
files are there (:mod:`~redservo.viewer.meshes`). The side panel has the run's summary, a
time slider, a play button, the camera image with the current (sky blue) and desired
(orange) features, and every joint's normalized position.

Once a page has drawn the scene (the robot included), it carries a hidden element
``<span id="redservo-drawn" data-drawn="true">`` (:data:`DRAWN_ID`): the server asks each new
page for a small render of its scene (viser's ``get_render``, which the page answers only after
it has applied the scene messages sent before and drawn a frame with them) and adds the
element when a render shows the robot's links. Scripts and tests wait for it, not for a fixed
time.

Why viser: docs/decisions.md ("3-D viewer").
"""

from __future__ import annotations

import itertools
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.plots.style import role_rgb
from redservo.viewer.obstacles import add_obstacles, place_obstacles
from redservo.viewer.playback import Frame, limit_color
from redservo.viewer.surfaces import add_objects, add_visuals, place, robot_visuals

if TYPE_CHECKING:  # pragma: no cover
    from redservo.viewer.playback import Playback

__all__ = ["DRAWN_ID", "LINK_COLOR", "TARGET_COLOR", "ViewerSession", "serve"]

LINK_COLOR = (142, 68, 173)
"""RGB of the robot's links (a purple no other element of the page uses)."""
TARGET_COLOR = role_rgb("target")
"""RGB of the target objects (:data:`redservo.plots.style.ROLE_COLORS`, as in every figure)."""
DRAWN_ID = "redservo-drawn"
"""``id`` of the hidden element a page gets once it has drawn the scene (module docstring)."""


def _viser() -> Any:
    try:
        import viser
    except ImportError:
        raise ConfigurationError(
            "redservo view needs viser: pip install 'redservo[viewer]'"
        ) from None
    return viser


def _wxyz(R: FloatArray) -> FloatArray:
    import viser.transforms as vtf

    return np.asarray(vtf.SO3.from_matrix(R).wxyz)


@dataclass
class ViewerSession:
    """A running viewer: its server, the frames shown and the URL."""

    server: Any
    playback: Playback
    frames: list[int]
    url: str
    handles: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    """What could not be drawn (e.g. a URDF's missing mesh files), printed by :func:`serve`."""
    playing: threading.Event = field(default_factory=threading.Event)
    stopped: threading.Event = field(default_factory=threading.Event)

    def show(self, index: int) -> None:
        """Show frame ``index`` (into :attr:`frames`)."""
        k = self.frames[int(np.clip(index, 0, len(self.frames) - 1))]
        _update(self, self.playback.frame(k))

    def stop(self) -> None:
        """Stop the player thread and the server."""
        self.stopped.set()
        self.server.stop()


def _segments(fr: Frame) -> FloatArray:
    origins = [T[:3, 3] for T in fr.links.values()] + [fr.bMc[:3, 3]]
    return np.array([[a, b] for a, b in itertools.pairwise(origins)])


def _axis_bars(fr: Frame, half: float) -> tuple[FloatArray, Any]:
    pts = np.array([[p - half * d, p + half * d] for p, d, _ in fr.axes])
    cols = np.array([[limit_color(float(v))] * 2 for v in fr.levels], dtype=np.uint8)
    return pts, cols


def _joint_table(s: ViewerSession, k: int) -> str:
    pb = s.playback
    lines = ["| joint | normalized q |", "|---|---:|"]
    for name, v, lvl in zip(pb.joint_names, pb.qn[k], limit_level_row(pb, k)):
        mark = " ⚠" if lvl >= 1.0 else (" •" if lvl > 0 else "")
        lines.append(f"| {name} | {v:+.3f}{mark} |")
    return "\n".join(lines)


def limit_level_row(pb: Playback, k: int) -> FloatArray:
    from redservo.viewer.playback import limit_level

    return limit_level(pb.qn[k], pb.rho)


def _update(s: ViewerSession, fr: Frame) -> None:
    from redservo.viewer.image import camera_image

    h, scale = s.handles, s.handles["scale"]
    with s.server.atomic():
        h["links"].points = _segments(fr)
        pts, cols = _axis_bars(fr, 0.12 * scale)
        h["axes"].points = pts
        h["axes"].colors = cols
        for j, (p, _, _) in enumerate(fr.axes):
            h[f"joint{j}"].position = p
            h[f"joint{j}"].color = limit_color(float(fr.levels[j]))
        h["camera"].position = fr.bMc[:3, 3]
        h["camera"].wxyz = _wxyz(fr.bMc[:3, :3])
        img = camera_image(s.playback, fr.k, width=320)
        h["camera"].image = img
        h["image"].image = img
        place(h["surfaces"], fr)
        place_obstacles(h["obstacles"], fr.t)
        h["time"].content = (
            f"**iteration {fr.k}** of {len(s.playback) - 1}, t = {fr.t:.2f} s, "
            f"‖e1‖ = {s.playback.run.arrays['error_norm'][fr.k]:.3g}"
        )
        h["joints"].content = _joint_table(s, fr.k)


def _build_scene(s: ViewerSession) -> None:
    server, pb = s.server, s.playback
    first = pb.frame(s.frames[0])
    cam_path = np.array([pb.exp.robot.fkine(pb.q[k], check_limits=False)[:3, 3] for k in s.frames])
    targets = [
        g.reshape(-1, 3) if k == "points" else np.reshape(g[0], (-1, 3))
        for _, k, g in first.objects
    ]
    allp = np.vstack([_segments(first).reshape(-1, 3), cam_path, *targets])
    span = float(np.ptp(allp, axis=0).max()) or 1.0
    scale = max(span, 0.3)
    h = s.handles
    h["scale"] = scale
    server.scene.set_up_direction("+z")
    server.scene.add_grid(
        "/grid", width=3 * scale, height=3 * scale, cell_size=0.1, section_size=0.5
    )
    server.scene.add_frame("/base", axes_length=0.2 * scale, axes_radius=0.006 * scale)
    h["links"] = server.scene.add_line_segments(
        "/robot/links", _segments(first), LINK_COLOR, thickness=0.025 * scale
    )
    pts, cols = _axis_bars(first, 0.12 * scale)
    h["axes"] = server.scene.add_line_segments("/robot/axes", pts, cols, thickness=0.012 * scale)
    for j, (p, _, _) in enumerate(first.axes):
        h[f"joint{j}"] = server.scene.add_icosphere(
            f"/robot/joint{j}",
            radius=0.03 * scale,
            color=limit_color(float(first.levels[j])),
            position=p,
        )
    cam = pb.exp.camera
    fov = 2.0 * float(np.arctan(cam.height / (2.0 * cam.py)))
    h["camera"] = server.scene.add_camera_frustum(
        "/camera",
        fov=fov,
        aspect=cam.width / cam.height,
        scale=0.15 * scale,
        color=(20, 20, 20),
        thickness=0.004 * scale,
        position=first.bMc[:3, 3],
        wxyz=_wxyz(first.bMc[:3, :3]),
    )
    segs = (
        np.stack([cam_path[:-1], cam_path[1:]], axis=1)
        if len(cam_path) > 1
        else np.zeros((0, 2, 3))
    )
    if len(segs):
        server.scene.add_line_segments(
            "/camera_path", segs, role_rgb("current"), thickness=0.004 * scale
        )
    visuals = robot_visuals(pb, set(first.links))
    s.notes.extend(visuals.notes)
    h["surfaces"] = add_visuals(server, visuals, first) + add_objects(
        server, pb, first, TARGET_COLOR, scale
    )
    centre = allp.mean(axis=0)
    server.initial_camera.look_at = centre
    server.initial_camera.position = centre + np.array([1.1, -1.3, 0.8]) * scale
    server.initial_camera.up = (0.0, 0.0, 1.0)


def _shows_links(img: Any) -> bool:
    """True when a rendered RGB(A) image has pixels of the links' hue (LINK_COLOR's purple)."""
    rgb = np.asarray(img)[..., :3].astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return int(((r - g > 25) & (b - g > 25)).sum()) >= 20


def _confirm_drawn(s: ViewerSession, client: Any) -> None:
    """Wait until ``client``'s page has drawn the robot, then mark the page (DRAWN_ID).

    Each request is answered with a frame drawn after the scene messages sent before it; viser
    sends scene messages and requests on separate queues, so a frame without the robot's
    links, or a failed capture, is asked for again (every 0.2 s, at most 300 times: the initial
    view always shows the robot, but a user may have turned away from it).
    """
    for _ in range(300):
        if s.stopped.is_set():
            return
        try:
            img = client.get_render(height=180, width=240)
        except Exception:  # a failed capture is asked again; a closed page is not
            if client.client_id not in s.server.get_clients():
                return
            img = None
        if img is not None and _shows_links(img):
            if not s.stopped.is_set():
                client.gui.add_html(f'<span id="{DRAWN_ID}" data-drawn="true" hidden></span>')
            return
        s.stopped.wait(0.2)


def _mark_drawn_pages(s: ViewerSession) -> None:
    @s.server.on_client_connect
    def _(client: Any) -> None:
        threading.Thread(
            target=_confirm_drawn, args=(s, client), daemon=True, name="redservo-viewer-drawn"
        ).start()


def _build_gui(s: ViewerSession) -> None:
    from redservo.records.verdict import outcome_text
    from redservo.viewer.image import camera_image

    server, pb, h = s.server, s.playback, s.handles
    summ = pb.run.summary
    server.gui.add_markdown(
        f"### {pb.run.name} [{pb.run.method}]\n{outcome_text(summ, pb.joint_names)}; "
        f"{summ.get('iterations', len(pb))} iterations; min margin "
        f"{summ.get('min_margin', float('nan')):.3f}"
    )
    h["time"] = server.gui.add_markdown("")
    slider = server.gui.add_slider("frame", 0, len(s.frames) - 1, 1, 0)
    play = server.gui.add_button("Play / pause")
    h["image"] = server.gui.add_image(camera_image(pb, s.frames[0], width=320), label="camera")
    h["joints"] = server.gui.add_markdown("")
    h["slider"] = slider

    @slider.on_update
    def _(_event: Any) -> None:
        s.show(int(slider.value))

    @play.on_click
    def _(_event: Any) -> None:
        if s.playing.is_set():
            s.playing.clear()
        else:
            if int(slider.value) >= len(s.frames) - 1:
                slider.value = 0
            s.playing.set()

    def player() -> None:
        while not s.stopped.wait(0.08):
            if s.playing.is_set():
                nxt = int(slider.value) + 1
                if nxt >= len(s.frames):
                    s.playing.clear()
                else:
                    slider.value = nxt

    threading.Thread(target=player, daemon=True, name="redservo-viewer-player").start()


def serve(
    playback: Playback,
    *,
    host: str = "127.0.0.1",
    port: int = 8080,
    max_frames: int = 200,
    block: bool = True,
) -> ViewerSession:
    """Start the viewer of ``playback`` on ``http://host:port``.

    Args:
        playback: The run to show (:class:`redservo.viewer.Playback`).
        host: Address to listen on (default: this machine only).
        port: TCP port.
        max_frames: At most this many iterations on the slider (evenly spaced, last kept).
        block: Serve until Ctrl-C (then stop); False returns the running session.

    Raises:
        ConfigurationError: viser is not installed.
    """
    viser = _viser()
    server = viser.ViserServer(host=host, port=port, verbose=False)
    session = ViewerSession(server, playback, playback.frames(max_frames), f"http://{host}:{port}")
    try:
        _build_scene(session)
        session.handles["obstacles"] = add_obstacles(server, playback.exp.obstacles, 0.0)
        _build_gui(session)
        session.show(0)
        _mark_drawn_pages(session)
    except BaseException:
        session.stop()
        raise
    for note in session.notes:
        print(f"view: {note}", file=sys.stderr, flush=True)
    if block:
        try:
            while True:
                time.sleep(1.0)
        except KeyboardInterrupt:
            pass
        finally:
            session.stop()
    return session
