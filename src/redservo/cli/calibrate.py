"""The calibration commands (:mod:`redservo.calibration`; need ``redservo[vision]``).

    redservo calibrate IMAGES... (--chessboard 9x6 --square 0.025 | --circles 7x5 --spacing 0.03)
                       [--distortion auto|none|k1|k1k2|k1k2p|full5]
                       [--out camera.yaml] [--poses-out poses.json]
    redservo calibrate-hand-eye POSES.json|csv [--mount hand|world] [--method tsai] [--out FILE]

Registered by :func:`register` into the parser (:mod:`redservo.cli.parser`).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

__all__ = ["register"]


def register(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add ``calibrate`` and ``calibrate-hand-eye`` to the ``redservo`` subparsers."""
    c = sub.add_parser(
        "calibrate",
        parents=[common],
        help="calibrate a camera from images of a chessboard or a circle grid (OpenCV)",
        description="Detect the pattern in every image, run cv2.calibrateCamera, print the RMS "
        "reprojection error and the points found per image, and write an OpenCV YAML file "
        "that scenarios read with [camera] file = ... (docs/vision.md, Calibration).",
    )
    c.add_argument("images", nargs="+", help="image files (any format OpenCV reads)")
    kind = c.add_mutually_exclusive_group(required=True)
    kind.add_argument(
        "--chessboard", metavar="COLSxROWS", help="inner corners of the chessboard, e.g. 9x6"
    )
    kind.add_argument(
        "--circles", metavar="COLSxROWS", help="circles of a symmetric circle grid, e.g. 7x5"
    )
    c.add_argument("--square", type=float, help="chessboard square side (m)")
    c.add_argument("--spacing", type=float, help="circle grid: distance between centres (m)")
    c.add_argument("--out", default="camera.yaml", help="output file (default camera.yaml)")
    c.add_argument(
        "--distortion",
        choices=("auto", "none", "k1", "k1k2", "k1k2p", "full5"),
        default="auto",
        help="distortion terms fitted: none, k1, k1k2, k1k2p (+ tangential p1 p2), full5 "
        "(+ k3); auto (default) by the number of distinct views and their coverage, and says "
        "which (docs/vision.md)",
    )
    c.add_argument(
        "--poses-out",
        metavar="FILE",
        help="also write the pattern's pose cMo in each image (JSON), the target poses of "
        "calibrate-hand-eye",
    )
    c.set_defaults(func=_cmd_calibrate)

    h = sub.add_parser(
        "calibrate-hand-eye",
        parents=[common],
        help="hand-eye calibration from robot and target pose pairs (OpenCV)",
        description="Solve eMc (camera on the robot) or the fixed camera's wMc from pairs of "
        "robot poses wMe and target poses cMo; print the residuals and the result in the "
        "scenario format (docs/vision.md, Hand-eye calibration).",
    )
    h.add_argument("poses", help="pose pairs: JSON [{wMe, cMo}, ...] or CSV (docs/vision.md)")
    h.add_argument(
        "--mount",
        choices=("hand", "world"),
        default="hand",
        help="hand: camera on the robot, gives eMc (default); world: fixed camera, gives wMc",
    )
    h.add_argument(
        "--method",
        choices=("tsai", "park", "horaud", "andreff", "daniilidis"),
        default="tsai",
        help="cv2.calibrateHandEye solver (default tsai)",
    )
    h.add_argument("--out", help="also write the TOML snippet into this file")
    h.set_defaults(func=_cmd_hand_eye)


def _usage(message: str) -> Exception:
    from redservo.errors import ConfigurationError

    return ConfigurationError(message)


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from redservo.calibration.files import save_camera
    from redservo.calibration.intrinsics import Pattern, calibrate_camera, parse_size

    pattern: Pattern
    if args.chessboard:
        if args.spacing is not None:
            raise _usage("--spacing is for --circles; a chessboard takes --square")
        if args.square is None:
            raise _usage("--chessboard needs --square (the square side, m)")
        pattern, size, spacing = (
            "chessboard",
            parse_size(args.chessboard, "--chessboard"),
            args.square,
        )
    else:
        if args.square is not None:
            raise _usage("--square is for --chessboard; a circle grid takes --spacing")
        if args.spacing is None:
            raise _usage("--circles needs --spacing (the distance between centres, m)")
        pattern, size, spacing = "circles", parse_size(args.circles, "--circles"), args.spacing
    if not (spacing > 0 and spacing < 10):
        raise _usage(
            f"the {'square' if args.chessboard else 'spacing'} must be in (0, 10) m, got {spacing}"
        )
    writable(args.out, "--out")  # before the work, not after
    if args.poses_out:
        writable(args.poses_out, "--poses-out")
    quiet = args.quiet

    def progress(name: str) -> None:
        if not quiet:
            print(f"detecting the {pattern} in {name}", file=sys.stderr, flush=True)

    res = calibrate_camera(
        args.images,
        pattern=pattern,
        size=size,
        spacing=spacing,
        progress=progress,
        distortion=args.distortion,
    )
    _report(res, "corners" if pattern == "chessboard" else "circles")
    out = save_camera(
        args.out,
        res.camera,
        rms_px=res.rms_px,
        n_images=res.used,
        pattern=f"{pattern} {size[0]}x{size[1]}",
        distortion_fit=res.model,
    )
    print(f"wrote {out}")
    if args.poses_out:
        used = res.used_names
        poses = [
            {"image": name, "cMo": [[round(float(v), 9) for v in row] for row in T]}
            for name, T in zip(used, res.poses, strict=True)
        ]
        with open(args.poses_out, "w") as fh:
            json.dump(poses, fh, indent=1)
            fh.write("\n")
        print(f"wrote {args.poses_out} (add each image's robot pose wMe for calibrate-hand-eye)")
    return 0


def _report(res: Any, what: str) -> None:
    """The per-image lines, the result and its model (stdout), the warnings (stderr)."""
    for k, (name, n, err) in enumerate(res.per_image):
        if not n:
            found = "pattern not found (not used)"
        elif k in res.duplicate_of:
            found = f"{n} {what}, repeats {res.per_image[res.duplicate_of[k]][0]} (not used)"
        else:
            found = f"{n} {what}, {err:.3f} px RMS"
        print(f"  {name}: {found}")
    c = res.camera
    print(
        f"RMS reprojection error {res.rms_px:.4f} px over {res.used} of {len(res.per_image)} "
        f"image(s); px = {c.px:.3f}, py = {c.py:.3f}, u0 = {c.u0:.3f}, v0 = {c.v0:.3f} "
        f"(pixel centres at +0.5), distortion k1, k2, p1, p2, k3 = "
        + ", ".join(f"{v:.5g}" for v in c.distortion)
    )
    print(
        f"distortion model {res.model} ({res.model_reason}); pattern coverage "
        f"{res.coverage:.0%} of the image, tilt spread {res.tilt_spread_deg:.1f} deg"
    )
    for line in res.warnings:
        print(f"warning: {line}", file=sys.stderr)


def writable(path: str, option: str) -> None:
    """Raise ConfigurationError naming ``option`` and ``path`` when no file can be written
    there (checked before a long computation, not after it)."""
    import os
    import tempfile
    from pathlib import Path

    from redservo.errors import ConfigurationError

    out = Path(path)
    try:
        if out.is_dir():
            raise IsADirectoryError(21, "is a folder")
        out.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out.parent):
            pass
        if out.exists() and not os.access(out, os.W_OK):
            raise PermissionError(13, "permission denied")
    except OSError as exc:
        raise ConfigurationError(
            f"{option} {out}: cannot write there ({exc.strerror or exc})", argument=option
        ) from None


def _cmd_hand_eye(args: argparse.Namespace) -> int:
    from redservo.calibration.hand_eye import hand_eye, load_pose_pairs, pose_toml

    if args.out:
        writable(args.out, "--out")
    wMe, cMo = load_pose_pairs(args.poses)
    res = hand_eye(wMe, cMo, mount=args.mount, method=args.method)
    other = "wMo (the fixed target)" if args.mount == "hand" else "eMo (the carried target)"
    print(
        f"{res.name} from {res.n_pairs} pose pairs by {res.solver}; residuals, spread of "
        f"{other} over the pairs: rotation {res.rot_rms_deg:.4g} deg RMS "
        f"({res.rot_max_deg:.4g} max), translation {res.trans_rms_m * 1e3:.4g} mm RMS "
        f"({res.trans_max_m * 1e3:.4g} max)"
    )
    text = pose_toml(res)
    print(text, end="")
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text)
        print(f"wrote {args.out}")
    return 0
