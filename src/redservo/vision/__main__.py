"""Measure dots in a real video, image folder or webcam: ``python -m redservo.vision SOURCE``.

Prints one line per frame with the dots' normalized coordinates ``x y`` (the
point features), and optionally writes the frames with the tracked dots to a
GIF or MP4. Examples::

    python -m redservo.vision 0 --dots 4 --frames 100          # first webcam
    python -m redservo.vision shots/ --dark --gif dots.gif     # an image folder
    python -m redservo.vision clip.avi --px 800 --py 800 --u0 320 --v0 240
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

import numpy as np

from redservo.camera import Camera
from redservo.errors import RedservoError


def main(argv: Sequence[str] | None = None) -> int:
    """Run the dot tracker on a source; return the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m redservo.vision", description=__doc__.split("\n")[0]
    )
    parser.add_argument("source", help="camera index (0), image folder, or video file")
    parser.add_argument(
        "--dots", type=int, default=None, help="number of dots (default: first frame)"
    )
    parser.add_argument("--threshold", default="otsu", help="gray level or 'otsu' (default)")
    parser.add_argument("--dark", action="store_true", help="dark dots on a bright background")
    parser.add_argument("--frames", type=int, default=None, help="stop after this many frames")
    parser.add_argument("--max-size", type=float, default=30.0, help="largest dot (pixels)")
    parser.add_argument("--px", type=float, default=600.0, help="focal length, pixels")
    parser.add_argument("--py", type=float, default=600.0, help="focal length, pixels")
    parser.add_argument("--u0", type=float, default=320.0, help="principal point, pixels")
    parser.add_argument("--v0", type=float, default=240.0, help="principal point, pixels")
    parser.add_argument("--k1", type=float, default=0.0, help="radial distortion k1")
    parser.add_argument("--gif", default=None, help="write the frames with the dots (.gif or .mp4)")
    args = parser.parse_args(argv)
    from redservo.vision.sources import frames, iter_dots
    from redservo.vision.video import write_video

    threshold: float | str = args.threshold if args.threshold == "otsu" else float(args.threshold)
    camera = Camera(args.px, args.py, args.u0, args.v0)
    try:
        # With --gif the frames are kept (read once); otherwise they stream.
        source = list(frames(args.source, max_frames=args.frames)) if args.gif else args.source
        result = []
        for fr in iter_dots(
            source,
            args.dots,
            camera=camera,
            distortion=args.k1,
            threshold=threshold,
            polarity="dark" if args.dark else "bright",
            max_size_px=args.max_size,
            max_frames=args.frames,
        ):
            result.append(fr)
            coords = " ".join(f"{x:+.4f} {y:+.4f}" for x, y in fr.xy)
            print(f"frame {fr.frame}: {coords}" + (f"  [{fr.reason}]" if fr.reason else ""))
        if args.gif:
            write_video(
                args.gif,
                source,
                camera=camera,
                distortion=args.k1,
                dots_uv=[fr.uv for fr in result],
                detected=[None if np.isnan(fr.xy).any() else fr.xy.ravel() for fr in result],
            )
            print(f"wrote {args.gif}")
    except RedservoError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
