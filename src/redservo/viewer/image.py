"""The camera image of a frame, drawn with Pillow: what the camera sees, the current and the
desired features, and the feature trajectories so far.

Not a photometric rendering (that is :mod:`redservo.vision.render`, which needs OpenCV):
a schematic image that needs only Pillow (``redservo[viewer]``). In the colours of
:data:`redservo.plots.style.ROLE_COLORS` (the same in the run figures, the ``--video`` GIFs
and the 3-D views): objects in the ``target`` colour (points as dots, a sphere's limb, a
cylinder's axis or a line), the current point features as sky-blue circles with their
trajectory, the desired ones as orange crosses, and with ``task.desired_pose`` the objects
seen from the desired pose in orange.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo.errors import ConfigurationError
from redservo.plots.style import role_rgb

if TYPE_CHECKING:  # pragma: no cover
    from redservo.viewer.playback import Playback

__all__ = ["camera_image"]

_BG = (28, 30, 36)
_OBJ = role_rgb("target")
_CUR = role_rgb("current")
_DES = role_rgb("desired")


def _pil() -> Any:
    try:
        from PIL import Image, ImageDraw
    except ImportError:
        raise ConfigurationError(
            "the camera image needs Pillow: pip install 'redservo[viewer]'"
        ) from None
    return Image, ImageDraw


def _font(width: int) -> Any:
    """Pillow's default font at a size readable in the image (its bitmap font before 10.1)."""
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=max(12, width // 28))
    except (TypeError, ImportError, OSError):  # pragma: no cover - Pillow < 10.1, no FreeType
        return ImageFont.load_default()


def camera_image(pb: Playback, k: int, *, width: int = 480) -> NDArray[np.uint8]:
    """(H, W, 3) RGB image of iteration ``k`` (0-based), ``width`` pixels wide."""
    Image, ImageDraw = _pil()
    cam = pb.exp.camera
    scale = width / cam.width
    h = max(1, round(cam.height * scale))
    img = Image.new("RGB", (width, h), _BG)
    draw = ImageDraw.Draw(img)

    def px(xy: NDArray[np.float64]) -> list[tuple[float, float]]:
        uv = cam.normalized_to_pixel(np.asarray(xy).reshape(-1, 2)) * scale
        ok = np.all(np.isfinite(uv), axis=1) & np.all(np.abs(uv) < 1e5, axis=1)
        return [(float(u), float(v)) for u, v in uv[ok]]

    r = max(2.0, 3.0 * scale)
    for kind, xy in pb.desired_projected:
        pts = px(xy)
        if kind == "points":
            for u, v in pts:
                draw.ellipse((u - r, v - r, u + r, v + r), outline=_DES)
        elif len(pts) > 1:
            for a, b in zip(pts[::2], pts[1::2]):
                draw.line((a, b), fill=_DES, width=1)
    for kind, xy in pb.projected(k):
        pts = px(xy)
        if kind == "points":
            for u, v in pts:
                draw.ellipse((u - r, v - r, u + r, v + r), fill=_OBJ)
        elif len(pts) > 1:
            closed = [*pts, pts[0]] if kind == "sphere" else pts
            draw.line(closed, fill=_OBJ, width=2)
    if pb.point_slices:
        for ix, iy in pb.point_slices:
            trail = px(pb.s[: k + 1][:, [ix, iy]])
            if len(trail) > 1:
                draw.line(trail, fill=_CUR, width=1)
        for u, v in px(pb.desired_xy):
            c = 2.5 * r
            draw.line((u - c, v, u + c, v), fill=_DES, width=2)
            draw.line((u, v - c, u, v + c), fill=_DES, width=2)
        for u, v in px(pb.current_xy(k)):
            c = 1.8 * r
            draw.ellipse((u - c, v - c, u + c, v + c), outline=_CUR, width=2)
    draw.rectangle((0, 0, width - 1, h - 1), outline=(90, 90, 90))
    draw.text((6, 4), f"k = {k}, t = {pb.t[k]:.2f} s", fill=(230, 230, 230), font=_font(width))
    return np.asarray(img, dtype=np.uint8)
