"""Measure dots in a real video, image folder or webcam: ``python -m redservo.vision SOURCE``.

Prints one line per frame with the dots' normalized coordinates ``x y`` (the
point features), and optionally writes the frames with the tracked dots to a
GIF or MP4. Examples::

    python -m redservo.vision 0 --dots 4 --frames 100          # first webcam
    python -m redservo.vision shots/ --dark --gif dots.gif     # an image folder
    python -m redservo.vision clip.avi --px 800 --py 800 --u0 320 --v0 240
    python -m redservo.vision clip.avi --tags 36h11 --tag-size 0.05 --camera cam.yaml
    python -m redservo.vision run.bag --tags 36h11 --tag-size 0.05   # a ROS bag, its camera_info

With ``--tags`` it prints the tags of each frame instead (:mod:`redservo.vision.tagcli`).

A video read only in part (fewer frames than its container announces, frames that could not be
decoded: they keep their numbers, printed as ``frame k: damaged ...``) is said on stderr as one
line ``python -m redservo.vision: warning: ...``.

Exit codes, as for ``redservo``: 0 on success; 2 on bad input (a bad option, a missing or
unreadable source, an image over the size cap, a file in an image folder that is not a
regular file, an output that cannot be written), printed as one line
``python -m redservo.vision: error: ...`` on stderr; 1 on an unexpected internal error
(``--debug`` shows the traceback); 130 when interrupted.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import sys
import tempfile
import traceback
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from redservo.camera import Camera
from redservo.errors import ConfigurationError, RedservoError
from redservo.vision.capture import VideoWarning
from redservo.vision.tagcli import add_tag_arguments, run_tags

__all__ = ["MAX_COUNT", "MAX_DOTS", "PROG", "main"]

PROG = "python -m redservo.vision"

MAX_DOTS = 10_000
"""Largest ``--dots``."""
MAX_COUNT = 10**9
"""Largest ``--frames``."""


class _UsageError(Exception):
    """A command-line usage error (one line, exit code 2)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{message} (see '{self.prog} --help')")


def _count(hi: int) -> Callable[[str], int]:
    """An integer in [1, ``hi``] (a number of dots or frames)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
        if not 1 <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be in [1, {hi}], got {value}")
        return value

    parse.__name__ = "integer"
    return parse


def _number(positive: bool, hi: float = math.inf, lo: float = 0.0) -> Callable[[str], float]:
    """A finite number, > 0 and >= ``lo`` when ``positive``, at most ``hi`` in magnitude."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
        if positive and not (value > 0.0 and value >= lo):
            least = f"at least {lo:g}" if lo > 0.0 else "positive"
            raise argparse.ArgumentTypeError(f"must be {least}, got {value:g}")
        if abs(value) > hi:
            raise argparse.ArgumentTypeError(f"must be at most {hi:g} in magnitude, got {value:g}")
        return value

    parse.__name__ = "number"
    return parse


def _threshold(text: str) -> float | str:
    if text == "otsu":
        return text
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a gray level in [0, 255] or 'otsu', got {text!r}"
        ) from None
    if not 0.0 <= value <= 255.0:  # NaN fails too
        raise argparse.ArgumentTypeError(f"must be a gray level in [0, 255], got {text!r}")
    return value


def _output(text: str) -> Path:
    path = Path(text)
    if path.suffix.lower() not in (".gif", ".mp4"):
        raise argparse.ArgumentTypeError(f"{text}: the video format must be .gif or .mp4")
    return path


def _parser() -> _Parser:
    p = _Parser(prog=PROG, description=(__doc__ or "").split("\n")[0])
    p.add_argument("source", help="camera index (0), image folder, video file, or ROS bag")
    p.add_argument(
        "--dots", type=_count(MAX_DOTS), default=None, help="number of dots (default: first frame)"
    )
    p.add_argument(
        "--threshold", type=_threshold, default="otsu", help="gray level or 'otsu' (default)"
    )
    p.add_argument("--dark", action="store_true", help="dark dots on a bright background")
    p.add_argument(
        "--frames", type=_count(MAX_COUNT), default=None, help="stop after this many frames"
    )
    p.add_argument(
        "--max-size",
        type=_number(True, 1e5, lo=2.0),
        default=30.0,
        help="largest dot (pixels, at least 2, the smallest)",
    )
    p.add_argument("--px", type=_number(True, 1e7), default=600.0, help="focal length, pixels")
    p.add_argument("--py", type=_number(True, 1e7), default=600.0, help="focal length, pixels")
    p.add_argument("--u0", type=_number(False, 1e7), default=320.0, help="principal point, px")
    p.add_argument("--v0", type=_number(False, 1e7), default=240.0, help="principal point, px")
    p.add_argument("--k1", type=_number(False, 1.0), default=0.0, help="radial distortion k1")
    p.add_argument(
        "--gif", type=_output, default=None, help="write the frames with the dots (.gif or .mp4)"
    )
    add_tag_arguments(p, _number(True, 1e3))
    p.add_argument("--debug", action="store_true", help="show the traceback of an internal error")
    return p


def _check_writable(out: Path) -> None:
    """Raise ConfigurationError, naming ``out``, when the video could not be written there."""
    if out.is_dir():
        raise ConfigurationError(f"{out}: is a folder; --gif takes a file name (.gif or .mp4)")
    base = next((a for a in out.parents if a.exists()), None)
    if base is not None and not base.is_dir():
        raise ConfigurationError(f"{out}: cannot write the video there ({base} is not a folder)")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out.parent):
            pass
        if out.exists() and not os.access(out, os.W_OK):
            raise PermissionError(errno.EACCES, "permission denied")
    except OSError as exc:
        raise ConfigurationError(
            f"{out}: cannot write the video there ({exc.strerror or exc})"
        ) from None


def _run(args: argparse.Namespace) -> int:
    from redservo.vision.sources import FrameList, iter_dots, numbered_frames
    from redservo.vision.video import write_video

    if args.tags:
        if args.gif:
            raise _UsageError("--gif draws dots; it does not go with --tags")
        return run_tags(args)
    for flag, value in (("--camera", args.camera), ("--tag-size", args.tag_size)):
        if value is not None:
            raise _UsageError(
                f"{flag} goes with --tags; the dot tracker takes the intrinsics from "
                "--px --py --u0 --v0 --k1"
            )
    is_camera = args.source.isdigit()
    if args.gif and is_camera and args.frames is None:
        raise _UsageError("--gif with a camera needs --frames (the frames are kept in memory)")
    camera = Camera(args.px, args.py, args.u0, args.v0)
    if args.gif:
        _check_writable(args.gif)  # before reading every frame, not after
    # With --gif the frames are kept (read once, with their numbers); otherwise they stream.
    source: Any = args.source
    if args.gif:
        source = FrameList(numbered_frames(args.source, max_frames=args.frames))
    result = []
    for fr in iter_dots(
        source,
        args.dots,
        camera=camera,
        distortion=args.k1,
        threshold=args.threshold,
        polarity="dark" if args.dark else "bright",
        max_size_px=args.max_size,
        max_frames=args.frames,
    ):
        result.append(fr)
        coords = " ".join(f"{x:+.4f} {y:+.4f}" for x, y in fr.xy)
        print(f"frame {fr.frame}: {coords}" + (f"  [{fr.reason}]" if fr.reason else ""))
    if args.gif:
        kept = {k for k, _ in source}
        drawn = [fr for fr in result if fr.frame in kept]  # not the damaged frames' gaps
        write_video(
            args.gif,
            [img for _, img in source],
            camera=camera,
            distortion=args.k1,
            dots_uv=[fr.uv for fr in drawn],
            detected=[None if np.isnan(fr.xy).any() else fr.xy.ravel() for fr in drawn],
        )
        print(f"wrote {args.gif}")
    return 0


def _describe(exc: BaseException) -> tuple[int, str]:
    """Exit code and one-line message of an exception that ended the command."""
    if isinstance(exc, RedservoError | _UsageError):
        return 2, str(exc)
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return 2, f"{where}{exc.strerror or exc}"
    if isinstance(exc, MemoryError):
        return 2, "out of memory (fewer --frames, or smaller images)"
    return 1, (
        f"internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback, "
        "and please report it)"
    )


def _show_warning(message: Warning | str, *_: object, **__: object) -> None:
    """A warning (a truncated video, damaged frames) as one ``warning:`` line on stderr."""
    print(f"{PROG}: warning: {' '.join(str(message).split())}", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the dot tracker on a source; return the exit status (module docstring)."""
    try:
        args = _parser().parse_args(argv)
    except _UsageError as exc:
        print(f"{PROG}: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", VideoWarning)
            warnings.showwarning = _show_warning
            return _run(args)
    except KeyboardInterrupt:  # pragma: no cover - interactive
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        code, line = _describe(exc)
        if args.debug:
            traceback.print_exc()
        print(f"{PROG}: error: {' '.join(line.split())}", file=sys.stderr)
        return code


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
