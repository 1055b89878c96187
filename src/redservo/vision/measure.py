"""How the image sensor plans and measures the shipped feature kinds, declared by each kind
(``image_term`` and ``measure_image``, :mod:`redservo.features.kinds`).

* a point or the moments of a point set: the dots of its points among the dots the sensor
  tracks (:func:`dots_term`); its value from their normalized
  positions (:func:`measured_dots`, which a feature measured on dots reuses);
* a sphere: its ellipse (:func:`~redservo.vision.terms.measure_sphere`);
* a cylinder's limbs, a line's centre line: :func:`~redservo.vision.terms.measure_lines`.

Signatures: ``image_term(i, feature, target, scene, sets, depth) -> TermState``,
``measure_image(sensor, feature, st, image, set_xy, truth, notes, i) -> s | None``, with
``sensor`` the :class:`~redservo.vision.sensor.ImageSensor`, ``set_xy`` the tracked dots'
normalized positions (N, 2), ``truth`` the true ``s`` when known and ``notes`` the frame's
notes (a term not measured says why there). Units: normalized image coordinates.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, GeometryError
from redservo.features.kinds import feature_kind
from redservo.scene import PointSet
from redservo.vision.depth import DepthPolicy
from redservo.vision.moments import dot_moment_features
from redservo.vision.terms import TermState, measure_lines, measure_sphere

if TYPE_CHECKING:  # pragma: no cover
    from redservo.features import LineFeature, MomentFeatures, PointFeature, SphereFeature
    from redservo.scene import Scene

__all__ = [
    "dots_term",
    "line_term",
    "measure_dot_moments",
    "measure_dot_point",
    "measure_image_lines",
    "measure_image_sphere",
    "measured_dots",
    "moments_term",
    "point_term",
    "shape_term",
]


def dots_term(
    i: int,
    kind: str,
    pts: FloatArray,
    target: str,
    scene: Scene,
    sets: dict[str, FloatArray],
    depth: DepthPolicy,
) -> TermState:
    """The state of task term ``i``, a feature of ``kind`` measured on the points ``pts``
    (k, 3) (m, object frame) of the point set ``target``: the indices of its dots among the
    dots of ``sets`` (each point set's dots, in order; ``target``'s added if new) as one
    dot tracker follows them.

    Raises:
        ConfigurationError: ``target`` is not a point set, a point is not one of its dots, or
            ``depth='estimated'`` with a single dot.
    """
    obj = scene.object(target)
    if not isinstance(obj, PointSet):
        raise ConfigurationError(f"term {i}: target {target!r} is not a point set")
    if target not in sets:
        sets[target] = obj.points
    offset = 0
    for name, pts_ in sets.items():
        if name == target:
            break
        offset += len(pts_)
    idx = [int(np.argmin(np.linalg.norm(obj.points - p, axis=1))) for p in pts]
    if any(np.linalg.norm(obj.points[j] - p) > 1e-9 for j, p in zip(idx, pts)):
        raise ConfigurationError(
            f"term {i}: a point of the feature is not a dot of point set {target!r}; "
            "the image sensor measures only drawn dots"
        )
    if depth == "estimated" and len(obj.points) < 2:
        raise ConfigurationError(
            f"term {i}: depth='estimated' needs a point set of at least 2 dots "
            f"({target!r} has 1); use depth='desired' or 'true'"
        )
    return TermState(kind, np.array(idx) + offset)


def point_term(
    i: int,
    f: PointFeature,
    target: str,
    scene: Scene,
    sets: dict[str, FloatArray],
    depth: DepthPolicy,
) -> TermState:
    """A point feature: the dot of its point."""
    return dots_term(i, "point", f.point_o[None, :], target, scene, sets, depth)


def moments_term(
    i: int,
    f: MomentFeatures,
    target: str,
    scene: Scene,
    sets: dict[str, FloatArray],
    depth: DepthPolicy,
) -> TermState:
    """The moments of a point set: the dots of its points."""
    return dots_term(i, "moments", f.points_o, target, scene, sets, depth)


def shape_term(
    i: int, f: Any, target: str, scene: Scene, sets: dict[str, FloatArray], depth: DepthPolicy
) -> TermState:
    """A sphere or a cylinder: a detector state of its kind's name."""
    kind = feature_kind(f)
    assert kind is not None  # planned through its kind
    return TermState(kind.name)


def line_term(
    i: int,
    f: LineFeature,
    target: str,
    scene: Scene,
    sets: dict[str, FloatArray],
    depth: DepthPolicy,
) -> TermState:
    """A line (refused with ``depth='estimated'``: a line has no known size).

    Raises:
        ConfigurationError: ``depth='estimated'``.
    """
    if depth == "estimated":
        raise ConfigurationError(
            f"term {i}: depth='estimated' is not available for a line (no known "
            "size); use depth='desired' or 'true'"
        )
    return TermState("line")


def measured_dots(
    sensor: Any, st: TermState, set_xy: FloatArray, notes: list[str], i: int
) -> FloatArray | None:
    """The normalized positions (k, 2) of the term's dots this frame (a lost dot at its
    predicted position, said in ``notes`` and in ``st.lost_dots``), or None when a dot was
    never seen."""
    if getattr(sensor, "all_dots_seen", False):  # the common frame: nothing to say
        st.lost_dots = False
        seen: FloatArray = set_xy[st.dots]
        return seen
    st.lost_dots = not bool(sensor._detected[st.dots].all())
    xy: FloatArray = set_xy[st.dots]
    if not np.isfinite(xy).all():
        notes.append(f"term {i}: a dot was never seen")
        return None
    if st.lost_dots:
        notes.append(f"term {i}: dot(s) lost, using their predicted positions")
    return xy


def measure_dot_point(
    sensor: Any,
    f: PointFeature,
    st: TermState,
    image: NDArray[np.uint8],
    set_xy: FloatArray,
    truth: FloatArray | None,
    notes: list[str],
    i: int,
) -> FloatArray | None:
    """A point: its dot's normalized position."""
    xy = measured_dots(sensor, st, set_xy, notes, i)
    return None if xy is None else np.asarray(xy[0], dtype=float)


def measure_dot_moments(
    sensor: Any,
    f: MomentFeatures,
    st: TermState,
    image: NDArray[np.uint8],
    set_xy: FloatArray,
    truth: FloatArray | None,
    notes: list[str],
    i: int,
) -> FloatArray | None:
    """The moments of the set's dots (:func:`~redservo.vision.moments.dot_moment_features`)."""
    xy = measured_dots(sensor, st, set_xy, notes, i)
    if xy is None:
        return None
    try:
        return dot_moment_features(xy, f)
    except GeometryError as exc:
        notes.append(f"term {i}: {exc}")
        return None


def noted(
    s: FloatArray | None, why: str, st: TermState, notes: list[str], i: int
) -> FloatArray | None:
    """``s``; when it is None, ``why`` goes to ``notes`` with the term and its kind."""
    if s is None:
        notes.append(f"term {i} ({st.kind}): {why}")
    return s


def measure_image_sphere(
    sensor: Any,
    f: SphereFeature,
    st: TermState,
    image: NDArray[np.uint8],
    set_xy: FloatArray,
    truth: FloatArray | None,
    notes: list[str],
    i: int,
) -> FloatArray | None:
    """A sphere's ellipse near its last centre (:func:`~redservo.vision.terms.measure_sphere`)."""
    s, why = measure_sphere(image, sensor.renderer, st, f, sensor.ellipse_method, truth)
    return noted(s, why, st, notes, i)


def measure_image_lines(
    sensor: Any,
    f: Any,
    st: TermState,
    image: NDArray[np.uint8],
    set_xy: FloatArray,
    truth: FloatArray | None,
    notes: list[str],
    i: int,
) -> FloatArray | None:
    """A cylinder's limbs or a line (:func:`~redservo.vision.terms.measure_lines`)."""
    s, why = measure_lines(image, sensor.renderer, st, truth)
    return noted(s, why, st, notes, i)
