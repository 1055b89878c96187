"""Task terms measured on a fiducial tag by :class:`~redservo.vision.sensor.ImageSensor`.

Two kinds of terms read a :class:`~redservo.scene.Tag` through :func:`detect_tags` (with the
renderer's intrinsics and distortion) instead of the dot tracker:

* a :class:`~redservo.features.PointFeature` on one of the tag's corners: the detected corner,
  normalized (undistorted); its inverse depth for ``depth="estimated"`` is ``1/Z`` of that
  corner in the detected pose;
* a pose feature (:class:`~redservo.features.PoseTranslation`,
  :class:`~redservo.features.PoseThetaU`, :class:`~redservo.features.LogDepth`): the feature of
  the detected pose ``cMo``, and its parameters for ``depth="estimated"`` from that pose.

Each frame is decoded once for all the terms of one tag. A tag not found (or its id not
among those found) leaves the term undetected with the reason; the sensor then coasts and,
after ``max_lost_frames``, reports ``feature_lost``. Of the two poses of the planar
ambiguity (:attr:`~redservo.vision.tags.TagDetection.cMo_alt`) the one nearer in rotation to
the previous frame's is kept when both fit the corners about as well (within
:data:`AMBIGUITY_PX`): near a fronto-parallel view the better-fitting one flips from frame to
frame with the image noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.features import LogDepth, PointFeature, PoseThetaU, PoseTranslation
from redservo.scene import SceneObject, Tag
from redservo.vision.optics import Optics
from redservo.vision.tags import TagDetection, detect_tags
from redservo.vision.terms import TermState

__all__ = ["AMBIGUITY_PX", "TagTerm", "measure_tag", "tag_term"]

AMBIGUITY_PX = 0.1
"""The second pose of a tag may replace the first when it fits the corners within this much
more RMS reprojection error (pixels) and is nearer in rotation to the last pose."""

_LAST: dict[str, Any] = {}
"""The last frame decoded (compared by identity) and its detections per family and size."""


@dataclass
class TagTerm(TermState):
    """A term measured on a tag: the tag, and for a corner its index (else -1)."""

    tag: Tag | None = None
    corner: int = -1
    cMo: FloatArray | None = field(default=None, repr=False)
    """The last detected pose of the tag."""


def tag_term(i: int, feature: Any, obj: SceneObject) -> TagTerm | None:
    """The state of term ``i`` when it reads a tag, else None.

    Raises:
        ConfigurationError: a pose feature whose object is not a tag, or a point feature on a
            tag that is not one of its corners.
    """
    pose = isinstance(feature, PoseTranslation | PoseThetaU | LogDepth)
    if not isinstance(obj, Tag):
        if pose:
            raise ConfigurationError(
                f"term {i}: the image sensor measures a pose feature on a tag only; "
                f"{obj.name!r} is a {type(obj).__name__}"
            )
        return None
    if pose:
        return TagTerm("tag", tag=obj)
    if type(feature) is not PointFeature:
        return None
    d = np.linalg.norm(obj.points - feature.point_o, axis=1)
    k = int(np.argmin(d))
    if d[k] > 1e-9:
        raise ConfigurationError(
            f"term {i}: a point feature on tag {obj.name!r} must be one of its 4 corners"
        )
    return TagTerm("tag", tag=obj, corner=k)


def _detections(image: NDArray[np.uint8], optics: Optics, tag: Tag) -> list[TagDetection]:
    key = f"{tag.family}/{tag.size!r}"
    if _LAST.get("image") is not image:
        _LAST.clear()
        _LAST["image"] = image
    if key not in _LAST:
        _LAST[key] = detect_tags(image, tag.family, camera=optics, tag_size=tag.size)
    out: list[TagDetection] = _LAST[key]
    return out


def _angle(A: FloatArray | None, B: FloatArray) -> float:
    """Angle (rad) of the rotation between the rotations of two poses."""
    assert A is not None
    c = 0.5 * (float(np.trace(A[:3, :3].T @ B[:3, :3])) - 1.0)
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def measure_tag(
    image: NDArray[np.uint8], optics: Optics, st: TagTerm, feature: Any
) -> tuple[FloatArray | None, str]:
    """The term's value in ``image`` seen through ``optics`` (and ``st.inv_depth``), or None and
    why."""
    tag = st.tag
    assert tag is not None
    found = [d for d in _detections(image, optics, tag) if d.id == tag.tag_id]
    if not found:
        return None, f"tag {tag.family} id {tag.tag_id} not detected"
    det = found[0]
    if det.cMo is None:  # pragma: no cover - IPPE returns a pose for any four corners
        return None, f"tag {tag.family} id {tag.tag_id}: no pose from its corners"
    cMo = det.cMo
    if (  # the planar ambiguity: as good a fit, and nearer the last pose
        st.cMo is not None
        and det.cMo_alt is not None
        and det.reprojection_alt_px <= det.reprojection_px + AMBIGUITY_PX
        and _angle(st.cMo, det.cMo_alt) < _angle(st.cMo, det.cMo)
    ):
        cMo = det.cMo_alt
    st.cMo = cMo
    if st.corner >= 0:
        P = cMo[:3, :3] @ tag.points[st.corner] + cMo[:3, 3]
        st.inv_depth = np.array([1.0 / P[2]]) if P[2] > 0.0 else st.inv_depth
        return optics.to_normalized(det.corners[st.corner]), ""
    meas = feature.measure(cMo)
    st.inv_depth = meas.inv_depth
    return np.asarray(meas.s, dtype=float), ""
