"""A new feature kind in one file: the image segment between two points of a point set.

``s = (xm, ym, l, α)``: the midpoint of the segment ``p1 p2`` (normalized image
coordinates), its length ``l`` (normalized units) and its orientation ``α`` (rad, wrapped to
(-π, π]), with ``inv_depth = (1/Z1, 1/Z2)`` (1/m). With ``u = (cos α, sin α)`` and
``u⊥ = (-sin α, cos α)``, the ends are ``p1,2 = m ∓ (l/2) u`` and, from the points'
interaction matrices ``L1``, ``L2`` (CM01 eq. 26):

    L_m = (L1 + L2)/2,    L_l = uᵀ (L2 - L1),    L_α = u⊥ᵀ (L2 - L1) / l.

Everything a feature kind needs is below: the feature (:class:`~redservo.features.Feature`),
its ``[[features]]`` entry (a :class:`~redservo.schema.features.FeatureSpec`) and its
declaration (:func:`~redservo.features.register_feature`) with the image sensor's adapters:
how a term is planned on the tracked dots, measured from them, its depth estimated and
drawn in the video (docs/extending.md, "Add a feature kind"). The point set is drawn by the point kind, so the
renderer, MuJoCo and the viewer need nothing new. Register the kind before loading a
scenario that uses it (here: at import).

    python examples/custom_feature_segment.py [--quick]
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

import redservo
from redservo._validation import as_transform
from redservo.camera import MIN_DEPTH
from redservo.errors import ConfigurationError, GeometryError
from redservo.features import Feature, Measurement, point_interaction, register_feature
from redservo.records import outcome_text
from redservo.scene import SceneObject
from redservo.schema.features import FeatureSpec
from redservo.schema.scene import ObjectSpec
from redservo.vision.depth import DepthPolicy, set_depth
from redservo.vision.measure import dots_term, measured_dots
from redservo.vision.optics import require_cv2
from redservo.vision.overlay import px
from redservo.vision.terms import TermState

FloatArray = NDArray[np.float64]


def segment_value(xy: ArrayLike) -> FloatArray:
    """``(xm, ym, l, α)`` of the image segment from ``xy[0]`` to ``xy[1]`` ((2, 2), normalized).

    Raises:
        GeometryError: the two ends coincide in the image (no orientation).
    """
    p = np.asarray(xy, dtype=float)
    d = p[1] - p[0]
    length = float(np.hypot(d[0], d[1]))
    if not length > 1e-12:
        raise GeometryError("the segment's ends coincide in the image; it has no orientation")
    m = 0.5 * (p[0] + p[1])
    return np.array([m[0], m[1], length, np.arctan2(d[1], d[0])])


class SegmentFeature(Feature):
    """The image segment ``s = (xm, ym, l, α)`` of two points fixed in the object frame
    (module docstring); ``inv_depth = (1/Z1, 1/Z2)`` (1/m).

    Args:
        p1, p2: (3,) the two ends in the object frame (m), distinct.
    """

    names = ("xm", "ym", "l", "alpha")
    angular = (False, False, False, True)

    def __init__(self, p1: ArrayLike, p2: ArrayLike) -> None:
        self.points_o = np.array([p1, p2], dtype=float).reshape(2, 3)
        if not np.isfinite(self.points_o).all() or np.allclose(*self.points_o):
            raise ConfigurationError("a segment needs two distinct finite ends", argument="ends")

    def measure(self, cMo: FloatArray) -> Measurement:
        T = as_transform(cMo, "cMo")
        P = self.points_o @ T[:3, :3].T + T[:3, 3]
        if not (P[:, 2] > MIN_DEPTH).all():
            raise GeometryError(f"a segment end is at or behind the camera plane (Z = {P[:, 2]} m)")
        return Measurement(segment_value(P[:, :2] / P[:, 2:]), 1.0 / P[:, 2])

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        xm, ym, length, alpha = np.asarray(s, dtype=float)
        u = np.array([np.cos(alpha), np.sin(alpha)])
        ends = np.array([xm, ym]) + 0.5 * length * np.array([-u, u])
        L1, L2 = (point_interaction(x, y, rho) for (x, y), rho in zip(ends, inv_depth))
        dL = L2 - L1
        return np.vstack([0.5 * (L1 + L2), u @ dL, np.array([-u[1], u[0]]) @ dL / length])


class SegmentSpec(FeatureSpec):
    """``[[features]]`` entry: the segment between points ``ends`` of a ``points`` object."""

    kind: Literal["segment"]
    ends: list[int] = Field(min_length=2, max_length=2, description="its two points (0-based)")

    def size(self, obj: ObjectSpec) -> int:
        return 4

    def features(self, obj: SceneObject, desired: Mapping[str, FloatArray] | None) -> list[Feature]:
        pts = np.asarray(cast(Any, obj).points, dtype=np.float64)
        if not all(0 <= k < len(pts) for k in self.ends):
            raise ConfigurationError(
                f"[[features]] segment: ends must be point indices in [0, {len(pts) - 1}], "
                f"got {list(self.ends)}",
                argument="ends",
            )
        return [SegmentFeature(pts[self.ends[0]], pts[self.ends[1]])]


# -- the image sensor's adapters (redservo.features.kinds): the segment's ends are dots ------


def segment_term(
    i: int, f: SegmentFeature, target: str, scene: Any, sets: dict[str, Any], depth: DepthPolicy
) -> TermState:
    """Plan term ``i`` on the dots of its two ends (:func:`~redservo.vision.measure.dots_term`)."""
    return dots_term(i, "segment", f.points_o, target, scene, sets, depth)


def measure_segment(
    sensor: Any,
    f: SegmentFeature,
    st: TermState,
    image: Any,
    set_xy: FloatArray,
    truth: FloatArray | None,
    notes: list[str],
    i: int,
) -> FloatArray | None:
    """The segment of its two tracked dots, or None (the reason in ``notes``)."""
    xy = measured_dots(sensor, st, set_xy, notes, i)
    if xy is None:
        return None
    try:
        return segment_value(xy)
    except GeometryError as exc:
        notes.append(f"term {i}: {exc}")
        return None


def segment_depth(
    f: SegmentFeature, s: FloatArray, *, set_points: Any = None, set_xy: Any = None
) -> FloatArray:
    """``(1/Ẑ, 1/Ẑ)`` (1/m) with ``Ẑ`` the point set's depth from its dots (``depth =
    "estimated"``, :func:`~redservo.vision.depth.set_depth`)."""
    return np.full(2, 1.0 / set_depth(set_points, set_xy))


def draw_segment(img: Any, optics: Any, f: SegmentFeature, s: FloatArray, color: Any) -> None:
    """The video overlay (:mod:`redservo.vision.video`): the segment between its ends."""
    u = np.array([np.cos(s[3]), np.sin(s[3])])
    ends = s[:2] + 0.5 * s[2] * np.array([-u, u])
    (u1, v1), (u2, v2) = px(optics, ends)
    require_cv2().line(img, (int(u1), int(v1)), (int(u2), int(v2)), color, 2)


KIND = register_feature(
    "segment",
    SegmentFeature,
    schema=SegmentSpec,
    obj="redservo.scene:PointSet",
    image_term=segment_term,
    measure_image=measure_segment,
    depth=segment_depth,
    draw=draw_segment,
)

SCENARIO: dict[str, Any] = {
    "name": "panda-segments",
    "description": "Panda, the two diagonals of a square as image segments",
    "robot": {"model": "panda", "q0": [0.0, -0.785, 0.0, -2.2, 0.0, 1.571, 0.785]},
    "objects": [
        {
            "name": "target",
            "kind": "points",
            "points": [[-0.1, -0.1, 0.0], [0.1, -0.1, 0.0], [0.1, 0.1, 0.0], [-0.1, 0.1, 0.0]],
            "pose_in_camera": {"translation": [-0.04, 0.03, 0.5], "rotvec": [-0.1, 0.12, -0.3]},
        }
    ],
    "features": [
        {"kind": "segment", "object": "target", "ends": [0, 2]},
        {"kind": "segment", "object": "target", "ends": [1, 3]},
    ],
    "task": {"desired_pose": {"translation": [0.0, 0.0, 0.35]}},
    "control": {"method": "classical", "lam": 1.0, "dt": 0.04},
    "simulation": {"max_iterations": 400, "tolerance": 1e-3},
}
"""Two segments (the square's diagonals) on a Panda: 8 components, a 6-DOF task."""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (tests)")
    args = parser.parse_args(argv)
    iters: dict[str, Any] = {"max_iterations": 40} if args.quick else {}
    for sensor in ("ideal", "image"):
        overrides = {"sensor.kind": sensor}
        result = redservo.run(SCENARIO, overrides=overrides, **iters)
        print(f"{sensor:>5} sensor: {outcome_text(result.summary)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
