"""The error panel of a ``--video`` frame: ``|e|`` per frame up to the current one.

Log scale with decade ticks (``1e-3``) when every value is positive, else linear with three
ticks. The margins are sized from the labels' rendered sizes (OpenCV's Hershey font) so that
no tick label or caption leaves the panel; :func:`panel_layout` gives every label's box, which
the tests check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.plots.style import role_rgb
from redservo.vision.optics import require_cv2

__all__ = ["PanelLayout", "error_panel", "panel_layout"]

_FONT_SCALE = 0.45


@dataclass(frozen=True)
class PanelLayout:
    """Where the error panel draws (pixels, origin top left).

    Attributes:
        box: ``(x0, y0, x1, y1)`` of the plot area.
        log: The values are plotted as ``log10 |e|``.
        lo, hi: The plotted range (log10 values when ``log``).
        texts: Every label ``(text, (x, y) baseline origin, (x0, y0, x1, y1) box)``.
    """

    box: tuple[int, int, int, int]
    log: bool
    lo: float
    hi: float
    ticks: tuple[tuple[int, str], ...]
    texts: tuple[tuple[str, tuple[int, int], tuple[int, int, int, int]], ...]


def _ticks(lo: float, hi: float, log: bool) -> tuple[float, float, list[tuple[float, str]]]:
    """The plotted range (widened to whole decades on a log scale) and its tick values."""
    if log:
        a, b = int(np.floor(lo)), int(np.ceil(hi))
        b = b if b > a else a + 1
        step = max(1, int(np.ceil((b - a) / 5)))
        return float(a), float(b), [(float(d), f"1e{d}") for d in range(a, b + 1, step)]
    mid = 0.5 * (lo + hi)
    return lo, hi, [(v, f"{v:.3g}") for v in (lo, mid, hi)]


def panel_layout(errors: FloatArray, k: int, height: int, width: int) -> PanelLayout:
    """The layout of the error panel of frame ``k`` (0-based): the margins are sized from
    the labels' rendered sizes so that no tick label or caption leaves the panel."""
    cv2 = require_cv2()
    font, scale = cv2.FONT_HERSHEY_SIMPLEX, _FONT_SCALE
    finite = errors[np.isfinite(errors)]
    log = bool(finite.size) and bool(np.all(finite > 0.0))
    vals = np.log10(finite) if log else finite
    lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
    if hi - lo < 1e-12:
        lo, hi = lo - 1.0, hi + 1.0
    lo, hi, ticks = _ticks(lo, hi, log)

    def size(text: str) -> tuple[int, int, int]:
        (w, h), base = cv2.getTextSize(text, font, scale, 1)
        return int(w), int(h), int(base)

    line = size("Ag")[1] + size("Ag")[2] + 6
    x0 = 8 + max(size(t)[0] for _, t in ticks) + 10
    y0, x1, y1 = line + 8, width - 12, height - 2 * line - 8
    texts = []

    def put(text: str, x: int, y: int) -> None:
        w, h, base = size(text)
        x = int(np.clip(x, 0, max(width - w, 0)))
        y = int(np.clip(y, h, max(height - base, h)))
        texts.append((text, (x, y), (x, y - h, x + w, y + base)))

    pix = []
    for v, label in ticks:
        yv = round(y1 - (v - lo) / (hi - lo) * (y1 - y0))
        pix.append((yv, label))
        w, h, _ = size(label)
        put(label, x0 - 8 - w, yv + h // 2)
    put("|e| (log scale)" if log else "|e|", x0, y0 - 8)
    now = errors[k] if 0 <= k < len(errors) else float("nan")
    put(f"frame {k} of {max(len(errors) - 1, 0)}", x0, y1 + line + 2)
    put(f"|e| = {now:.3g}", x0, y1 + 2 * line + 2)
    return PanelLayout((x0, y0, x1, y1), log, lo, hi, tuple(pix), tuple(texts))


def error_panel(errors: FloatArray, k: int, height: int, width: int) -> NDArray[np.uint8]:
    """The error-norm panel (height, width, 3) with the curve up to frame ``k``."""
    cv2 = require_cv2()
    panel = np.full((height, width, 3), 255, np.uint8)
    lay = panel_layout(errors, k, height, width)
    x0, y0, x1, y1 = lay.box
    cv2.rectangle(panel, (x0, y0), (x1, y1), (0, 0, 0), 1)
    for yv, _ in lay.ticks:
        cv2.line(panel, (x0 - 4, yv), (x0, yv), (0, 0, 0), 1)
    for text, org, _ in lay.texts:
        cv2.putText(
            panel, text, org, cv2.FONT_HERSHEY_SIMPLEX, _FONT_SCALE, (0, 0, 0), 1, cv2.LINE_AA
        )
    with np.errstate(divide="ignore", invalid="ignore"):
        vals = np.log10(errors) if lay.log else errors
    n = max(len(errors) - 1, 1)
    xs = x0 + (np.arange(k + 1) / n) * (x1 - x0)
    ys = y1 - (vals[: k + 1] - lay.lo) / (lay.hi - lay.lo) * (y1 - y0)
    ok = np.isfinite(ys)
    pts = np.stack([xs[ok], ys[ok]], 1).round().astype(np.int32)
    color = role_rgb("error")
    if pts.shape[0] > 1:
        cv2.polylines(panel, [pts.reshape(-1, 1, 2)], False, color, 2, cv2.LINE_AA)
    if pts.shape[0]:
        cv2.circle(panel, (int(pts[-1, 0]), int(pts[-1, 1])), 4, color, -1, cv2.LINE_AA)
    return panel
