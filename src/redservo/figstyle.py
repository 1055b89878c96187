"""The house style of every figure, and how figures become files.

matplotlib is imported lazily (``pip install 'redservo[plot]'``). Shared by the run,
comparison, campaign and reproduction figures (:mod:`redservo.plots` draws the run and
comparison figures with it):

* :func:`savefig` writes one file per format (``png`` at 300 dpi, ``pdf``, ``svg``) with a
  tight bounding box, so no label is clipped; the formats come from the argument or from
  :func:`figure_formats` (the ``--format`` option of the command line);
* :func:`method_style` gives each method one fixed colour (and line style) in every
  figure, from a colour-blind-safe palette (Okabe & Ito 2008, completed with four colours
  of Paul Tol's "muted" scheme, and a dashed line where two colours are close).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from redservo.errors import ConfigurationError

__all__ = [
    "DPI",
    "FORMATS",
    "METHOD_STYLES",
    "clipped",
    "figure_formats",
    "method_style",
    "parse_formats",
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
    "large-projection": ("#44AA99", "--"),
}
"""(colour, line style) of each method, the same in every figure (colour-blind safe)."""
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
