"""``redservo animate PATH --out run.gif|mp4``: a video of a saved run.

Each frame shows, side by side: the 3-D scene (robot links, joint axes coloured by their
closeness to the limits as in the viewer, camera frustum and path, target objects; base
frame, m), the camera image with the current and desired features
(:func:`redservo.viewer.image.camera_image`), and the normalized joint positions with
their thresholds ``±(1 - 2 rho)`` (CM01 eq. 3) and limits ``±1`` up to the current time.

Drawn with matplotlib (``redservo[plot]``) and written with Pillow (GIF) or, for MP4, an
encoder already installed (imageio-ffmpeg, or OpenCV's ``mp4v``); nothing is downloaded,
and without an MP4 encoder the error says to write a ``.gif``.
"""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo.errors import ConfigurationError
from redservo.plots.style import ROLE_COLORS
from redservo.viewer.obstacles import posed_outline
from redservo.viewer.playback import Frame, limit_color
from redservo.vision.video import Progress, _write_mp4, write_gif

if TYPE_CHECKING:  # pragma: no cover
    from redservo.viewer.playback import Playback

__all__ = ["write_animation"]

_LINK = "#8E44AD"  # the viewer's LINK_COLOR
_TARGET = ROLE_COLORS["target"]
_OBSTACLE = "#D9731A"  # the viewer's OBSTACLE_COLOR
_FONT = {"suptitle": 15, "title": 13, "label": 12, "tick": 10, "legend": 10}
"""Font sizes (points) of the frames: readable in a GIF shown at its size (1280 x 560 px)."""
_SIZE = (12.8, 5.6)
"""Frame size (inches) at the default 100 dpi."""


def _frustum(bMc: NDArray[np.float64], cam: Any, size: float) -> NDArray[np.float64]:
    """Segments (8, 2, 3) of the camera's view pyramid, ``size`` m deep (base frame)."""
    w, h = cam.width / (2 * cam.px), cam.height / (2 * cam.py)
    corners = np.array([[-w, -h, 1], [w, -h, 1], [w, h, 1], [-w, h, 1]]) * size
    P = corners @ bMc[:3, :3].T + bMc[:3, 3]
    o = bMc[:3, 3]
    segs = [[o, p] for p in P] + [[P[i], P[(i + 1) % 4]] for i in range(4)]
    return np.array(segs)


def _polyline(segs: NDArray[np.float64]) -> NDArray[np.float64]:
    """Segments (S, 2, 3) as one polyline with NaN breaks (S * 3, 3)."""
    gap = np.full((segs.shape[0], 1, 3), np.nan)
    return np.concatenate([segs, gap], axis=1).reshape(-1, 3)


class _Scene3D:
    """The 3-D panel: artists made once, moved at each frame (a redraw from scratch is slow)."""

    def __init__(self, ax: Any, pb: Playback, lims: NDArray[np.float64]) -> None:
        self.ax, self.pb = ax, pb
        self.path = np.array([pb.exp.robot.fkine(q, check_limits=False)[:3, 3] for q in pb.q])
        self.half = 0.06 * float(np.ptp(lims, axis=1).max())
        (self.links,) = ax.plot([], [], [], "-", color=_LINK, lw=3.5, solid_capstyle="round")
        n = len(pb.joint_names)
        self.axes = [ax.plot([], [], [], lw=3)[0] for _ in range(n)]
        self.joints = ax.scatter(np.zeros(n), np.zeros(n), np.zeros(n), s=18, depthshade=False)
        (self.frustum,) = ax.plot([], [], [], color="0.15", lw=0.8)
        (self.trail,) = ax.plot([], [], [], color=ROLE_COLORS["current"], lw=1.5)
        self.objects: list[Any] = []
        for _, kind, _geo in pb.frame(0).objects:
            if kind in ("points", "sphere"):
                size = 10 if kind == "points" else 60
                self.objects.append(
                    ax.scatter([0], [0], [0], color=_TARGET, s=size, depthshade=False)
                )
            else:
                self.objects.append(ax.plot([], [], [], color=_TARGET, lw=3)[0])
        self.obstacles = [ax.plot([], [], [], color=_OBSTACLE, lw=1.2)[0] for _ in pb.exp.obstacles]
        ax.set(xlim=lims[0], ylim=lims[1], zlim=lims[2])
        ax.set_box_aspect(np.ptp(lims, axis=1))
        for name, axis in zip("xyz", (ax.set_xlabel, ax.set_ylabel, ax.set_zlabel)):
            axis(f"{name} (m)", fontsize=_FONT["label"], labelpad=-4)
        ax.tick_params(labelsize=_FONT["tick"], pad=-2)
        for a in (ax.xaxis, ax.yaxis, ax.zaxis):
            a.set_major_locator(_locator(4))

    def update(self, fr: Frame) -> None:
        chain = arm_chain(self.pb.exp.robot, fr.links)
        pts = np.array([T[:3, 3] for T in chain] + [fr.bMc[:3, 3]])
        self.links.set_data_3d(pts[:, 0], pts[:, 1], pts[:, 2])
        colors = []
        for line, (p, d, _), lvl in zip(self.axes, fr.axes, fr.levels):
            c = np.array(limit_color(float(lvl))) / 255
            seg = np.array([p - self.half * d, p + self.half * d])
            line.set_data_3d(seg[:, 0], seg[:, 1], seg[:, 2])
            line.set_color(c)
            colors.append(c)
        P = np.array([p for p, _, _ in fr.axes])
        self.joints._offsets3d = (P[:, 0], P[:, 1], P[:, 2])
        self.joints.set_color(colors)
        f = _polyline(_frustum(fr.bMc, self.pb.exp.camera, 1.2 * self.half))
        self.frustum.set_data_3d(f[:, 0], f[:, 1], f[:, 2])
        tr = self.path[: fr.k + 1]
        self.trail.set_data_3d(tr[:, 0], tr[:, 1], tr[:, 2])
        for artist, (_, kind, geo) in zip(self.objects, fr.objects):
            if kind == "points":
                artist._offsets3d = (geo[:, 0], geo[:, 1], geo[:, 2])
            elif kind == "sphere":
                artist._offsets3d = ([geo[0][0]], [geo[0][1]], [geo[0][2]])
            else:
                artist.set_data_3d(geo[0][:, 0], geo[0][:, 1], geo[0][:, 2])
        for line, ob in zip(self.obstacles, self.pb.exp.obstacles):
            o = posed_outline(ob, fr.t)
            line.set_data_3d(o[:, 0], o[:, 1], o[:, 2])
        self.ax.set_title(f"t = {fr.t:.2f} s (iteration {fr.k})", fontsize=_FONT["title"])


def arm_chain(robot: Any, links: dict[str, NDArray[np.float64]]) -> list[NDArray[np.float64]]:
    """The link poses the 3-D panel joins with sticks: for a URDF robot the chain from its
    base to the link carrying the camera (``chain_links``; wheels, casters, antennas and any
    other branch of the kinematic tree are left out), otherwise every link (the DH and
    Afma6 models only list their chain), base to tip."""
    names = getattr(robot, "chain_links", None)
    if not names:
        return list(links.values())
    return [links[n] for n in names if n in links]


def _locator(n: int) -> Any:
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(n)


def _limits(pb: Playback, ks: list[int]) -> NDArray[np.float64]:
    pts = []
    for k in [*ks[:: max(1, len(ks) // 20)], ks[-1]]:
        fr = pb.frame(k)
        pts += [T[:3, 3] for T in arm_chain(pb.exp.robot, fr.links)] + [fr.bMc[:3, 3]]
        for _, kind, geo in fr.objects:
            pts += (
                list(geo.reshape(-1, 3))
                if kind == "points"
                else [np.asarray(geo[0]).reshape(-1, 3)[0]]
            )
    P = np.array(pts)
    c, half = 0.5 * (P.min(0) + P.max(0)), 0.55 * float(np.ptp(P, axis=0).max()) + 0.05
    return np.array([[c[i] - half, c[i] + half] for i in range(3)])


def _frames(
    pb: Playback, ks: list[int], dpi: int, progress: Progress | None = None
) -> list[NDArray[np.uint8]]:
    from redservo.plots.style import _plt
    from redservo.records.verdict import outcome_text
    from redservo.viewer.image import camera_image

    plt = _plt()
    fig = plt.figure(figsize=_SIZE, dpi=dpi, layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=(1.15, 1.0))
    ax3 = fig.add_subplot(grid[:, 0], projection="3d")
    axi = fig.add_subplot(grid[0, 1])
    axj = fig.add_subplot(grid[1, 1])
    title = f"{pb.run.name} [{pb.run.method}]: {outcome_text(pb.run.summary, pb.joint_names)}"
    fig.suptitle(textwrap.fill(title, 110), fontsize=_FONT["suptitle"])  # the verdict may be long
    scene = _Scene3D(ax3, pb, _limits(pb, ks))
    t, qn, edge = pb.t, pb.qn, 1 - 2 * pb.rho
    for y in (edge, -edge):
        axj.axhline(y, color="0.5", ls="--", lw=0.8)
    for y in (1.0, -1.0):
        axj.axhline(y, color="k", lw=0.8)
    lines = [axj.plot([], [], lw=1.1, label=n)[0] for n in pb.joint_names]
    axj.set(xlim=(t[0], max(t[-1], t[0] + 1e-9)), ylim=(-1.08, 1.08))
    axj.set_xlabel("t (s)", fontsize=_FONT["label"])
    axj.set_ylabel("normalized q (-)", fontsize=_FONT["label"])
    axj.tick_params(labelsize=_FONT["tick"])
    axj.legend(
        fontsize=_FONT["legend"],
        loc="upper left",
        bbox_to_anchor=(1.0, 1.0),
        frameon=False,
        ncol=1 + (len(lines) > 7),
    )
    cursor = axj.axvline(t[0], color="0.3", lw=0.8)
    image = axi.imshow(camera_image(pb, ks[0]))
    axi.set_axis_off()
    axi.set_title("camera: current (sky blue), desired (orange)", fontsize=_FONT["title"])
    out = []
    for i, k in enumerate(ks):
        scene.update(pb.frame(k))
        image.set_data(camera_image(pb, k))
        for j, line in enumerate(lines):
            line.set_data(t[: k + 1], qn[: k + 1, j])
        cursor.set_xdata([t[k], t[k]])
        fig.canvas.draw()
        if fig.get_layout_engine() is not None:  # lay out once: the panels do not move
            fig.set_layout_engine("none")
        out.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
        if progress is not None:
            progress.frame(i)
    plt.close(fig)
    return out


def write_animation(
    pb: Playback,
    path: str | Path,
    *,
    fps: float = 12.0,
    max_frames: int = 120,
    dpi: int = 100,
    progress: bool = True,
) -> Path:
    """Write the video of a run (module docstring); returns ``path``.

    Args:
        pb: The run (:class:`redservo.viewer.Playback`).
        path: ``.gif`` or ``.mp4``.
        fps: Frames per second.
        max_frames: At most this many frames (evenly spaced iterations, the last kept).
        dpi: Resolution (the frame is 12.8 x 5.6 inches: 1280 x 560 pixels at 100 dpi).
        progress: Say on stderr how far it is (about every tenth of the frames, then while
            encoding): a GIF of 60 frames takes tens of seconds.

    Raises:
        ConfigurationError: another extension; no MP4 encoder (the message says to use
            ``.gif``); Pillow or matplotlib missing.
    """
    out = Path(path)
    ext = out.suffix.lower()
    if ext not in (".gif", ".mp4"):
        raise ConfigurationError(
            f"--out {out}: the video format must be .gif or .mp4, got {ext or 'no extension'!r}",
            argument="out",
        )
    if not fps > 0:
        raise ConfigurationError(f"--fps must be positive, got {fps}", argument="fps")
    ks = pb.frames(max_frames)
    said = Progress("animate", len(ks), enabled=progress)
    if progress:
        print(f"animate: drawing {len(ks)} frames of {pb.run.name}", file=sys.stderr, flush=True)
    rgb = _frames(pb, ks, dpi, said)
    said.writing(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if ext == ".mp4":
        _write_mp4(out, rgb, fps)
    else:
        write_gif(out, rgb, fps)
    return out
