"""Fiducial tag families: names, OpenCV dictionaries, bits and number of ids (pure data), and
the tag frame.

Shared by the scene's :class:`~redservo.scene.Tag` (which checks a family and an id without
importing OpenCV) and :mod:`redservo.vision.tags` (which builds the ``cv2.aruco`` dictionary).

Tag frame (ViSP's ``vpDetectorAprilTag`` frame): origin at the tag centre, the tag in the plane
``z = 0``, ``z`` out of its printed face; corner ``k`` is ``size/2`` times
``(-1, -1), (1, -1), (1, 1), (-1, 1)`` (AprilTag 3's corner order), ``size`` the side of the
black border (the renderer adds a one-cell white margin).
Each entry is ``name: (cv2.aruco dictionary constant, bits per side, number of ids)``; the
tag is drawn ``bits + 2`` cells wide (a one-cell black border) on a one-cell white margin.
"""

from __future__ import annotations

import numpy as np

from redservo.errors import ConfigurationError, GeometryError, UnknownNameError

__all__ = ["TAG_FAMILIES", "check_tag", "tag_points"]

TAG_FAMILIES: dict[str, tuple[str, int, int]] = {
    "36h11": ("DICT_APRILTAG_36h11", 6, 587),
    "36h10": ("DICT_APRILTAG_36h10", 6, 2320),
    "25h9": ("DICT_APRILTAG_25h9", 5, 35),
    "16h5": ("DICT_APRILTAG_16h5", 4, 30),
    "aruco_original": ("DICT_ARUCO_ORIGINAL", 5, 1024),
    "aruco_mip_36h12": ("DICT_ARUCO_MIP_36h12", 6, 250),
}
"""AprilTag families (AprilTag 3 names without ``tag``) and the ArUco dictionaries."""
for _bits in (4, 5, 6, 7):
    for _n in (50, 100, 250, 1000):
        TAG_FAMILIES[f"aruco_{_bits}x{_bits}_{_n}"] = (f"DICT_{_bits}X{_bits}_{_n}", _bits, _n)


def check_tag(family: str, tag_id: int | None = None) -> str:
    """Return the canonical family name (``"tag36h11"`` and ``"36H11"`` give ``"36h11"``).

    Raises:
        UnknownNameError: an unknown family (the message lists them).
        ConfigurationError: ``tag_id`` is not an id of the family.
    """
    key = str(family).strip().lower()
    key = key.removeprefix("tag")
    if key.startswith(("4x4", "5x5", "6x6", "7x7", "original", "mip")):
        key = "aruco_" + key
    if key not in TAG_FAMILIES:
        raise UnknownNameError(f"unknown tag family {family!r}; allowed: {', '.join(TAG_FAMILIES)}")
    if tag_id is not None:
        n = TAG_FAMILIES[key][2]
        if isinstance(tag_id, bool) or not isinstance(tag_id, int) or not 0 <= tag_id < n:
            raise ConfigurationError(
                f"tag id must be an integer in [0, {n - 1}] for family {key!r}, got {tag_id!r}"
            )
    return key


def tag_points(size: float) -> np.ndarray:
    """(4, 3) the corners (m) of a tag of side ``size`` in its frame (module docstring).

    Raises:
        GeometryError: ``size`` is not positive and finite.
    """
    s = float(size)
    if not (np.isfinite(s) and s > 0.0):
        raise GeometryError(f"tag size must be positive and finite (m), got {size!r}")
    h = 0.5 * s
    return np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
