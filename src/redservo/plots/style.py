"""The house style of every figure, and how figures become files.

matplotlib is imported lazily (``pip install 'redservo[plot]'``). Shared by the run,
comparison, campaign and reproduction figures (:mod:`redservo.plots.figures` draws the run and
comparison figures with it):

* :func:`savefig` writes one file per format (``png`` at 300 dpi, ``pdf``, ``svg``) with a
  tight bounding box, so no label is clipped; the formats come from the argument or from
  :func:`figure_formats` (the ``--format`` option of the command line);
* :func:`method_style` gives each method one fixed colour (and line style) in every
  figure, from a colour-blind-safe palette (Okabe & Ito 2008, completed with four colours
  of Paul Tol's "muted" scheme, and a dashed line where two colours are close);
* :data:`ROLE_COLORS` gives each *role* one colour in every picture: the current features
  (sky blue) and the desired ones (orange) are the same in the run figures, the ``--video``
  GIFs, ``redservo animate`` and the viewer (:func:`role_rgb` for drawing code in 0-255 RGB);
* :func:`place_legend` puts a legend in the corner of an axes that no data reaches, or
  outside the axes when every corner has data.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from redservo.errors import ConfigurationError

__all__ = [
    "CURRENT_COLOR",
    "DESIRED_COLOR",
    "DPI",
    "FORMATS",
    "METHOD_STYLES",
    "ROLE_COLORS",
    "clipped",
    "figure_formats",
    "method_style",
    "parse_formats",
    "place_legend",
    "role_rgb",
    "save",
    "savefig",
]

FORMATS = ("png", "pdf", "svg")
"""Formats :func:`savefig` writes."""
DPI = 300
"""Resolution of PNG files (dots per inch)."""

METHOD_STYLES: dict[str, tuple[str, str]] = {
    "classical": ("#000000", "-"),
    "gpm": ("#E69F00", "-"),
    "gpm-auto": ("#D55E00", "--"),
    "iterative-basic": ("#56B4E9", "-"),
    "iterative": ("#0072B2", "-"),
    "iterative-smooth": ("#009E73", "-"),
    "iterative-smooth-e2": ("#117733", "--"),
    "directional": ("#CC79A7", "-"),
    "wln": ("#882255", "-"),
    "sns": ("#332288", "--"),
    "qp": ("#999933", "-"),
    "qp-goal": ("#999933", "-."),
    "large-projection": ("#44AA99", "--"),
    "predictive": ("#AA4499", "-."),
}
"""(colour, line style) of each method, the same in every figure (colour-blind safe)."""
CURRENT_COLOR = "#56B4E9"
"""The current (measured) features: trajectories, circles (Okabe-Ito sky blue)."""
DESIRED_COLOR = "#E69F00"
"""The desired features ``s*``: crosses, dashed outlines (Okabe-Ito orange)."""
ROLE_COLORS: dict[str, str] = {
    "current": CURRENT_COLOR,
    "desired": DESIRED_COLOR,
    "target": "#009E73",
    "error": "#000000",
}
"""One colour per role in every figure, video and viewer page: the ``current`` and
``desired`` features, the ``target`` object (3-D objects, their image, tracked image dots),
the ``error`` curve."""
_OTHERS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#D55E00", "#56B4E9", "#882255")
_formats: tuple[str, ...] = ("png",)


def method_style(label: str, index: int = 0) -> dict[str, str]:
    """``{"color", "linestyle"}`` of a method (or of a label starting with a method name,
    e.g. ``"gpm α=2"``: same colour, dotted); other labels cycle through the palette."""
    if label in METHOD_STYLES:
        color, ls = METHOD_STYLES[label]
        return {"color": color, "linestyle": ls}
    base = label.split()[0] if label.split() else label
    if base in METHOD_STYLES:
        return {"color": METHOD_STYLES[base][0], "linestyle": ":"}
    return {"color": _OTHERS[index % len(_OTHERS)], "linestyle": "-"}


def role_rgb(role: str) -> tuple[int, int, int]:
    """The colour of a role of :data:`ROLE_COLORS` as 0-255 ``(r, g, b)`` (OpenCV on RGB
    images, Pillow, viser).

    Raises:
        ConfigurationError: an unknown role (lists the roles).
    """
    if role not in ROLE_COLORS:
        raise ConfigurationError(
            f"unknown colour role {role!r}; roles: {', '.join(ROLE_COLORS)}", argument="role"
        )
    h = ROLE_COLORS[role].lstrip("#")
    return int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16)


def _data_in_axes(ax: Any) -> Any:
    """(N, 2) positions (axes fraction) of the points of every line and collection of ``ax``."""
    import numpy as np

    pts = [np.zeros((0, 2))]
    for line in ax.get_lines():  # reference lines (axhline: 2 points, no label) do not count
        xy = np.asarray(line.get_xydata(), dtype=float)
        if xy.ndim == 2 and (len(xy) > 2 or not str(line.get_label()).startswith("_")):
            pts.append(xy)
    for coll in ax.collections:
        off = np.asarray(coll.get_offsets(), dtype=float)
        if off.ndim == 2 and len(off):
            pts.append(off)
    data = np.concatenate(pts)
    data = data[np.all(np.isfinite(data), axis=1)]
    if not len(data):
        return data
    ax.get_xlim(), ax.get_ylim()  # applies a pending autoscale, so transData is final
    disp = ax.transData.transform(data)
    return ax.transAxes.inverted().transform(disp)


_CORNERS = ("upper right", "upper left", "lower left", "lower right")


def _legend_box(ax: Any, legend: Any) -> Any:
    """The legend's box in axes fraction ``(x0, y0, x1, y1)``, slightly padded."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = ax.figure
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    renderer = canvas.get_renderer()
    legend.draw(renderer)  # places it (a legend finds its offset when drawn)
    box = legend.get_window_extent(renderer)
    (x0, y0), (x1, y1) = ax.transAxes.inverted().transform([[box.x0, box.y0], [box.x1, box.y1]])
    return np.array([x0 - 0.01, y0 - 0.01, x1 + 0.01, y1 + 0.01])


def place_legend(ax: Any, *, outside: bool = False, **kwargs: Any) -> Any:
    """Add the legend of ``ax`` where it hides no data; return it.

    The first corner (upper right, upper left, lower left, lower right) where the legend,
    as drawn, covers no data point is used; when it would cover data in every corner, or
    with ``outside=True``, the legend goes outside, to the right of the axes (one column).
    Keyword arguments go to ``ax.legend`` (e.g. ``fontsize``, ``ncol``).
    """
    import numpy as np

    kwargs.setdefault("fontsize", 7)
    if not outside:
        xy = _data_in_axes(ax)
        for loc in _CORNERS:
            legend = ax.legend(loc=loc, **kwargs)
            x0, y0, x1, y1 = _legend_box(ax, legend)
            inside = (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
            if not np.any(inside):
                return legend
            legend.remove()
    kwargs.pop("ncol", None)
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, **kwargs)


def parse_formats(text: str | Sequence[str]) -> tuple[str, ...]:
    """``"png,pdf"`` -> ``("png", "pdf")``.

    Raises:
        ConfigurationError: an unknown format (names ``--format`` and the allowed ones).
    """
    items = text.split(",") if isinstance(text, str) else list(text)
    out = tuple(dict.fromkeys(s.strip().lower().lstrip(".") for s in items if s.strip()))
    bad = [f for f in out if f not in FORMATS]
    if bad or not out:
        raise ConfigurationError(
            f"--format: unknown figure format {bad[0] if bad else text!r}; allowed: "
            f"{', '.join(FORMATS)} (comma-separated, e.g. png,pdf)",
            argument="format",
        )
    return out


@contextlib.contextmanager
def figure_formats(formats: Sequence[str]) -> Iterator[tuple[str, ...]]:
    """Within the block, :func:`savefig` and :func:`save` write these formats by default
    (none at all for an empty sequence: ``--no-plot``)."""
    global _formats
    before, _formats = _formats, (parse_formats(formats) if len(formats) else ())
    try:
        yield _formats
    finally:
        _formats = before


def _plt() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - optional dependency
        raise ImportError("figures need matplotlib: pip install 'redservo[plot]'") from exc
    return plt


def clipped(fig: Any, tol_px: float = 1.0) -> bool:
    """True when some artist (a label, a title, a legend) reaches outside the figure."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    renderer = canvas.get_renderer()
    fig.draw_without_rendering()
    tight, box = fig.get_tightbbox(renderer), fig.bbox_inches
    return bool(
        tight.x0 < box.x0 - tol_px / fig.dpi
        or tight.y0 < box.y0 - tol_px / fig.dpi
        or tight.x1 > box.x1 + tol_px / fig.dpi
        or tight.y1 > box.y1 + tol_px / fig.dpi
    )


def savefig(fig: Any, stem: Path | str, formats: Sequence[str] | None = None) -> list[Path]:
    """Write ``fig`` as ``stem.<format>`` for each format, then close it.

    PNG at :data:`DPI`; PDF with embedded TrueType fonts; every file with a tight bounding
    box (nothing clipped). A figure without a layout engine gets ``tight_layout`` first.

    Args:
        fig: A matplotlib figure.
        stem: Path without suffix (a suffix, if any, is replaced).
        formats: Among :data:`FORMATS` (default: :func:`figure_formats`' or ``png``).

    Returns:
        The paths written, in the order of ``formats``.
    """
    import matplotlib

    fmts = _formats if formats is None else parse_formats(formats)
    if not fmts:  # figures are off (--no-plot)
        _plt().close(fig)
        return []
    stem = Path(stem)
    stem = stem.with_suffix("") if stem.suffix.lower().lstrip(".") in FORMATS else stem
    stem.parent.mkdir(parents=True, exist_ok=True)
    if fig.get_layout_engine() is None:
        fig.tight_layout()
    paths = []
    with matplotlib.rc_context({"pdf.fonttype": 42, "svg.hashsalt": "redservo"}):
        for fmt in fmts:
            path = stem.parent / f"{stem.name}.{fmt}"
            meta = {"Date": None} if fmt in ("pdf", "svg") else {}
            fig.savefig(
                path, dpi=DPI, bbox_inches="tight", pad_inches=0.05, format=fmt, metadata=meta
            )
            paths.append(path)
    _plt().close(fig)
    return paths


def save(fig: Any, path: Path) -> Path:
    """Save ``fig`` like :func:`savefig` (stem of ``path``, the active formats) and return
    the first file written (the one a report links to)."""
    return savefig(fig, path)[0]
