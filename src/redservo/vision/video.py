"""Write the camera view as a GIF or MP4: detected and desired features, and the error beside it.

:func:`write_video` draws, on each frame (OpenCV drawing, anti-aliased):

* the tracked dots (``dots_uv``, pixels) as thin circles (role ``target``);
* the detected features ``s`` (role ``current``, sky blue) and the desired ``s*``
  (role ``desired``, orange: the colours of :data:`redservo.plots.style.ROLE_COLORS`, as in
  ``redservo animate`` and the viewer), term by term when a task is given — a point as a
  circle (current) or a cross (desired), a sphere as its ellipse, a cylinder's limbs and a
  line as lines, moments as the centroid ``(xn/an, yn/an)`` with a segment along the
  orientation α; without a task ``s`` is read as stacked points ``(x1, y1, x2, y2, ...)``;
* to the right, the error norm per frame (log scale, with decade ticks, when every value is
  positive) up to the current frame; every label of the panel lies inside it
  (:func:`redservo.vision.videopanel.panel_layout`).

Output by extension: ``.gif`` with Pillow (``pip install 'redservo[viewer]'``);
``.mp4`` with imageio-ffmpeg when installed, else OpenCV's ``mp4v`` encoder
when this OpenCV build has one, else a :class:`ConfigurationError` suggesting
``.gif``. Nothing is downloaded.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import ConfigurationError, ShapeError
from redservo.features.kinds import feature_adapter
from redservo.plots.style import role_rgb
from redservo.vision.optics import Optics, require_cv2
from redservo.vision.overlay import DESIRED, draw_point, px
from redservo.vision.videopanel import error_panel

if TYPE_CHECKING:  # pragma: no cover
    from redservo.task import VisualTask

__all__ = ["Progress", "compose_frame", "write_gif", "write_video"]

_CURRENT = role_rgb("current")
_DESIRED = DESIRED
_DOT = role_rgb("target")


def _draw_term(
    img: NDArray[np.uint8], optics: Optics, feature: Any, s: FloatArray, color: Any
) -> None:
    """The term's overlay its feature kind declares (``draw``, :mod:`redservo.vision.overlay`);
    nothing for a kind that declares none (a pose)."""
    draw = feature_adapter(feature, "draw")
    if draw is not None:
        draw(img, optics, feature, s, color)


def _draw_features(
    img: NDArray[np.uint8], optics: Optics, task: VisualTask | None, s: FloatArray, color: Any
) -> None:
    if task is None:
        for u, v in px(optics, s.reshape(-1, 2)):
            draw_point(img, int(u), int(v), color)
        return
    i = 0
    for term, size in zip(task.terms, task.sizes):
        _draw_term(img, optics, term.feature, s[i : i + size], color)
        i += size


def compose_frame(
    image: NDArray[np.uint8],
    optics: Optics,
    *,
    task: VisualTask | None = None,
    detected: FloatArray | None = None,
    desired: FloatArray | None = None,
    dots_uv: FloatArray | None = None,
    errors: FloatArray | None = None,
    k: int = 0,
) -> NDArray[np.uint8]:
    """One RGB frame (H, W [+ W/2], 3): the overlaid camera view and, if ``errors``, the plot."""
    cv2 = require_cv2()
    img = np.asarray(image)
    if img.ndim != 2 or img.dtype != np.uint8:
        raise ShapeError(f"frames must be 2-D uint8 images, got {img.dtype} of shape {img.shape}")
    rgb = cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
    if dots_uv is not None:
        for u, v in np.asarray(dots_uv, dtype=float).reshape(-1, 2):
            if np.isfinite(u) and np.isfinite(v):
                cv2.circle(rgb, (int(np.rint(u)), int(np.rint(v))), 7, _DOT, 1, cv2.LINE_AA)
    if desired is not None:
        _draw_features(rgb, optics, task, np.asarray(desired, dtype=float), _DESIRED)
    if detected is not None:
        _draw_features(rgb, optics, task, np.asarray(detected, dtype=float), _CURRENT)
    if errors is None:
        return rgb
    panel = error_panel(
        np.asarray(errors, dtype=float), k, img.shape[0], max(img.shape[1] // 2, 200)
    )
    return np.concatenate([rgb, panel], axis=1)


class Progress:
    """Says on stderr how far a video is: ``"<what>: frame i of n"`` about every tenth of
    the frames, then ``"<what>: writing <path>"`` (a long video is never silent).

    Args:
        what: The name in front of each line (e.g. ``"animate"``).
        n: The number of frames.
        enabled: False prints nothing.
    """

    def __init__(self, what: str, n: int, *, enabled: bool = True) -> None:
        self.what, self.n, self.enabled = what, n, enabled
        self.every = max(1, n // 10)

    def frame(self, i: int) -> None:
        """Frame ``i`` (0-based) is done."""
        if self.enabled and ((i + 1) % self.every == 0 or i + 1 == self.n):
            print(f"{self.what}: frame {i + 1} of {self.n}", file=sys.stderr, flush=True)

    def writing(self, path: Path) -> None:
        """The frames are done; the file is being encoded."""
        if self.enabled:
            print(f"{self.what}: writing {path}", file=sys.stderr, flush=True)


def _per_frame(value: Sequence[Any] | None, n: int, name: str) -> list[Any]:
    if value is None:
        return [None] * n
    if len(value) != n:
        raise ShapeError(f"{name} must have one entry per frame ({n}), got {len(value)}")
    return list(value)


def _write_mp4(path: Path, rgb: list[NDArray[np.uint8]], fps: float) -> None:
    try:
        import imageio.v2 as iio
        import imageio_ffmpeg  # noqa: F401

        with iio.get_writer(str(path), fps=fps, macro_block_size=1) as writer:
            for f in rgb:
                writer.append_data(f)  # type: ignore[attr-defined]
        return
    except ImportError:
        pass
    cv2 = require_cv2()
    h, w = rgb[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), float(fps), (w, h))
    if not writer.isOpened():
        raise ConfigurationError(
            f"{path}: no MP4 encoder is available (neither imageio-ffmpeg nor an OpenCV mp4v "
            "encoder); write a .gif instead"
        )
    for f in rgb:
        writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    writer.release()


def write_video(
    path: str | Path,
    frames: Sequence[NDArray[np.uint8]],
    *,
    camera: Camera | None = None,
    distortion: float | tuple[float, float] = 0.0,
    task: VisualTask | None = None,
    detected: Sequence[FloatArray | None] | None = None,
    desired: FloatArray | None = None,
    errors: ArrayLike | None = None,
    dots_uv: Sequence[FloatArray | None] | None = None,
    fps: float = 10.0,
    progress: Progress | None = None,
) -> Path:
    """Write ``frames`` with overlays to ``path`` (``.gif`` or ``.mp4``); return the path.

    Args:
        path: Output file; its extension chooses the format.
        frames: The camera images, (H, W) uint8 each (e.g. ``SensorReading.image``).
        camera: Intrinsics the features are expressed with (default :class:`Camera`).
        distortion: Radial distortion ``k1`` or ``(k1, k2)`` of the images.
        task: The task whose terms give the layout of ``detected`` and ``desired``.
        detected: Per frame, the measured ``s`` (k,) or None.
        desired: The desired ``s*`` (k,), drawn on every frame.
        errors: Per frame, the error norm (e.g. ``|e1|``), plotted beside the view.
        dots_uv: Per frame, the tracked dots (N, 2) in pixels.
        fps: Frames per second.
        progress: Told of each frame composed and of the encoding (default: silent).

    Raises:
        ConfigurationError: unknown extension, no frames, or no encoder for ``.mp4``.
        ShapeError: per-frame inputs of the wrong length, frames not 2-D uint8.
    """
    out = Path(path)
    ext = out.suffix.lower()
    if ext not in (".gif", ".mp4"):
        raise ConfigurationError(f"{out}: the video format must be .gif or .mp4, got {ext!r}")
    if not frames:
        raise ConfigurationError("write_video needs at least one frame")
    if not fps > 0.0:
        raise ConfigurationError(f"fps must be positive, got {fps!r}")
    n = len(frames)
    k = np.atleast_1d(np.asarray(distortion, dtype=float))
    optics = Optics(camera or Camera(), float(k[0]), float(k[1]) if k.size > 1 else 0.0)
    det = _per_frame(detected, n, "detected")
    dots = _per_frame(dots_uv, n, "dots_uv")
    err = None if errors is None else np.asarray(errors, dtype=float).reshape(-1)
    if err is not None and err.shape[0] != n:
        raise ShapeError(f"errors must have one entry per frame ({n}), got {err.shape[0]}")
    rgb = []
    for i in range(n):
        rgb.append(
            compose_frame(
                frames[i],
                optics,
                task=task,
                detected=det[i],
                desired=desired,
                dots_uv=dots[i],
                errors=err,
                k=i,
            )
        )
        if progress is not None:
            progress.frame(i)
    if progress is not None:
        progress.writing(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if ext == ".mp4":
        _write_mp4(out, rgb, fps)
    else:
        write_gif(out, rgb, fps)
    return out


def write_gif(path: Path, rgb: Sequence[NDArray[np.uint8]], fps: float) -> None:
    """Write RGB frames (H, W, 3) as a looping GIF (128 colours) with Pillow.

    Raises:
        ConfigurationError: Pillow is not installed (``redservo[viewer]``).
    """
    try:
        from PIL import Image
    except ImportError:  # pragma: no cover - pillow is in the test extras
        raise ConfigurationError(
            "writing a GIF needs Pillow: pip install 'redservo[viewer]'"
        ) from None
    images = [Image.fromarray(f).quantize(colors=128) for f in rgb]
    images[0].save(
        path, save_all=True, append_images=images[1:], duration=round(1000.0 / fps), loop=0
    )
