"""``python -m redservo.vision SOURCE --tags FAMILY``: tags per frame (ids, corners, poses).

One line per detected tag and frame::

    frame 0 tag 3: corners u0 v0 u1 v1 u2 v2 u3 v3 px | t +x +y +z m | thetau +a +b +c rad | 0.02 px

(corners in the order and pixel convention of :func:`redservo.vision.detect_tags`; ``t`` and
``thetau`` the pose ``cMo`` in ViSP's tag frame, with ``--tag-size``; the last number the RMS
reprojection error), ``frame k: no tag``, or ``frame k: damaged (could not be decoded)`` for a
video frame that does not decode (the later frames keep their numbers). The camera is ``--camera FILE`` (an OpenCV or ROS
camera_info YAML, :func:`redservo.calibration.files.load_camera`), else a bag's own ``CameraInfo``
topic, else ``--px --py --u0 --v0 --k1``.
"""

from __future__ import annotations

import argparse
from typing import Any

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.spatial import matrix_to_rotvec

__all__ = ["add_tag_arguments", "camera_of", "format_tag", "run_tags"]


def add_tag_arguments(p: argparse.ArgumentParser, number: Any) -> None:
    """The tag options of the command line (``number``: the positive-number parser)."""
    p.add_argument("--tags", default=None, help="detect tags of this family (36h11, 25h9...)")
    p.add_argument("--tag-size", type=number, default=None, help="tag side (m), for the pose")
    p.add_argument("--camera", default=None, help="intrinsics file (OpenCV or ROS YAML)")


def camera_of(args: argparse.Namespace) -> Camera:
    """The camera: ``--camera`` file, a bag's CameraInfo, or the intrinsics flags."""
    if args.camera:
        from redservo.calibration.files import load_camera

        return load_camera(args.camera)
    from redservo.vision.bags import bag_camera, is_bag

    if is_bag(args.source):
        try:
            return bag_camera(args.source)
        except ConfigurationError:
            pass  # no CameraInfo topic: the flags
    return Camera(args.px, args.py, args.u0, args.v0, k1=args.k1)


def format_tag(frame: int, det: Any) -> str:
    """One output line for a detected tag (module docstring)."""
    uv = " ".join(f"{v:.3f}" for v in det.corners.ravel())
    line = f"frame {frame} tag {det.id}: corners {uv} px"
    if det.cMo is not None:
        t = " ".join(f"{v:+.5f}" for v in det.cMo[:3, 3])
        tu = " ".join(f"{v:+.5f}" for v in matrix_to_rotvec(det.cMo[:3, :3]))
        line += f" | t {t} m | thetau {tu} rad | {det.reprojection_px:.3f} px"
    return line


def run_tags(args: argparse.Namespace) -> int:
    """Print the tags of every frame of ``args.source``."""
    from redservo.vision.sources import numbered_frames
    from redservo.vision.tag_families import check_tag
    from redservo.vision.tags import detect_tags

    family = check_tag(args.tags)
    camera = camera_of(args)
    size = args.tag_size
    expected = 0
    for k, image in numbered_frames(args.source, max_frames=args.frames):
        for gap in range(expected, k):
            print(f"frame {gap}: damaged (could not be decoded)")
        expected = k + 1
        dets = detect_tags(image, family, camera=camera, tag_size=size)
        if not dets:
            print(f"frame {k}: no tag")
        for det in dets:
            print(format_tag(k, det))
    return 0
