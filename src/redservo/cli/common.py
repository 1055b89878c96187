"""What the ``redservo`` commands share: usage errors, option types, progress and summary lines.

Imported by :mod:`redservo.cli.entry` (the entry point), :mod:`redservo.cli.parser` (the
parser), :mod:`redservo.cli.commands` and :mod:`redservo.cli.tools` (the commands); it
imports none of them, so that the command line has no import cycle.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

__all__ = [
    "EXTRAS",
    "Parser",
    "UsageError",
    "add_figure_options",
    "draw_figures",
    "engine_note",
    "figures",
    "int_in",
    "method_list",
    "method_name",
    "progress",
    "require",
    "summary_line",
    "warn",
]

EXTRAS = {
    "cyclonedds": "ros2",
    "matplotlib": "plot",
    "tqdm": "progress",
    "qpsolvers": "qp",
    "daqp": "qp",
    "pinocchio": "urdf",
    "cv2": "vision",
    "numba": "fast",
    "distributed": "dask",
    "dask": "dask",
    "viser": "viewer",
    "imageio": "viewer",
    "PIL": "viewer",
    "pyarrow": "parquet",
}
"""Optional imports and the extra that installs them (pyproject.toml)."""


class UsageError(Exception):
    """A command-line usage error (reported in one line, exit code 2)."""


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are :class:`UsageError` (one line, exit code 2)."""

    def error(self, message: str) -> NoReturn:
        # No prog prefix: main() prints "redservo: error: " once; the hint names the command.
        raise UsageError(f"{message} (see '{self.prog} --help')")


def int_in(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse type: an integer in ``[lo, hi]``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be in [{lo}, {hi}], got {value}")
        return value

    parse.__name__ = "integer"
    return parse


def _known_methods() -> str:
    from redservo.redundancy import METHODS

    return ", ".join(METHODS)


def method_name(text: str) -> str:
    """An argparse type: one method name, not empty (``--method ''`` is a usage error,
    not the scenario's method). Unknown names are rejected where the method is built."""
    name = text.strip()
    if not name:
        raise argparse.ArgumentTypeError(
            f"give a method name, got {text!r}; methods: {_known_methods()}"
        )
    return name


def method_list(text: str) -> list[str]:
    """An argparse type: comma-separated method names, none of them empty."""
    names = [m.strip() for m in text.split(",")]
    if not all(names):
        raise argparse.ArgumentTypeError(
            f"give at least one method name, comma-separated with no empty entry, got {text!r}; "
            f"methods: {_known_methods()}"
        )
    return names


def require(module: str, what: str) -> None:
    """Fail early, in one line, when an optional dependency is missing."""
    import importlib.util

    try:
        found = importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        found = False
    if not found:
        raise ImportError(f"{what} need {module}: pip install 'redservo[{EXTRAS[module]}]'")


def progress(
    total: int, desc: str, enabled: bool
) -> tuple[Callable[[int], None], Callable[[], None]]:
    """Return (update, close) for a progress bar on stderr (tqdm if installed)."""
    if not enabled or not sys.stderr.isatty():
        return (lambda _i: None), (lambda: None)
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is an optional extra
        return (lambda _i: None), (lambda: None)
    bar = tqdm(total=total, desc=desc, unit="it", leave=False, file=sys.stderr)

    def update(i: int) -> None:
        bar.n = i + 1
        if i % 25 == 0:
            bar.refresh()

    return update, bar.close


def summary_line(name: str, summary: Mapping[str, Any], joints: Sequence[str] = ()) -> str:
    """One line per run: the outcome and the success verdict (why not, when not), then the
    numbers; joints and iterations numbered from 0 (README, Conventions)."""
    from redservo.records.verdict import outcome_text

    cam = summary["max_camera_speed"]
    ratio = summary.get("peak_velocity_ratio")
    closest = summary.get("min_distance")
    return (
        f"{name}: {outcome_text(summary, joints)}; {summary['iterations']} iterations, "
        f"final |e| = {summary['final_error_norm']:.3g}, min margin = {summary['min_margin']:.3f}, "
        f"max camera speed = {cam['translation']:.3g} m/s / {cam['rotation']:.3g} rad/s, "
        f"discontinuity = {summary['discontinuity']:.3g}"
        + (f", peak |q̇|/limit = {ratio:.2f}" if ratio is not None else "")
        + (
            f", min distance = {closest * 1000:.1f} mm ({summary.get('closest_pair')})"
            if closest is not None
            else ""
        )
    )


def engine_note(result: Any, prefix: str = "") -> None:
    """One ``note:`` line when a user's Python code took part in the run's control step."""
    if getattr(result, "engine", "compiled") == "python":
        print(f"note: {prefix}Python control step ({result.engine_reason})", file=sys.stderr)


def warn(summary: Any, prefix: str = "") -> None:
    """Print one ``warning:`` line per diagnostic flag raised in a run (stderr)."""
    from redservo.simulation import flag_warnings

    for line in flag_warnings(summary):
        print(f"warning: {prefix}{line}", file=sys.stderr)


def add_figure_options(p: argparse.ArgumentParser, default: str = "png") -> None:
    """``--format`` and ``--no-plot`` (shared by every command that writes figures)."""
    p.add_argument(
        "--format",
        default=default,
        metavar="FMT[,FMT]",
        help=f"figure formats among png (300 dpi), pdf, svg (default {default})",
    )
    p.add_argument("--no-plot", action="store_true", help="write no figures")


@contextlib.contextmanager
def figures(args: argparse.Namespace) -> Iterator[bool]:
    """Within the block, figures are written in ``--format`` (none with ``--no-plot``);
    yields whether figures are wanted."""
    from redservo.plots.style import figure_formats, parse_formats

    if getattr(args, "no_plot", False):
        with figure_formats(()):
            yield False
        return
    with figure_formats(parse_formats(getattr(args, "format", "png") or "png")):
        yield True


def draw_figures(args: argparse.Namespace, draw: Callable[[], list[Path]]) -> int:
    """Draw figures in ``--format`` unless ``--no-plot``; without matplotlib say so on
    stderr (the numbers are the result). Returns the number of figures."""
    import importlib.util

    with figures(args) as wanted:
        if not wanted:
            return 0
        if importlib.util.find_spec("matplotlib") is None:
            print("figures skipped: pip install 'redservo[plot]'", file=sys.stderr)
            return 0
        return len(draw())
