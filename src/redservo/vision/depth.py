"""Depth for the interaction matrices when the features come from an image.

An image gives ``s`` but not the depth its interaction matrix needs (the
inverse-depth parameters of :mod:`redservo.features.base`). The image sensor
offers three documented choices (``depth=``):

* ``"desired"`` (default): the parameters at the desired pose,
  ``task.inv_depth_star`` — constant, the classical choice of image-based
  servoing;
* ``"estimated"``: from the apparent size of the known object, per feature
  (:func:`estimate_inv_depth`, exact at σ = 0 where stated):

  - sphere of known radius ``r``: the ellipse's minor semi-axis ``b`` fixes
    ``Z0² - r² = r²/b²`` (the ellipse of :func:`~redservo.features.sphere.sphere_ellipse`
    has ``b² = r²/(Z0² - r²)``), so
    ``Z0 = r sqrt(1 + 1/b²)``, ``X0 = xc (Z0² - r²)/Z0``,
    ``Y0 = yc (Z0² - r²)/Z0`` and ``(A, B, C) = X0/(|X0|² - r²)``. Exact.
    (For ``s = (xc, yc, a)``, ``b²`` comes from the area by
    :func:`~redservo.features.sphere.sphere_moments_from_area`.)
  - cylinder of known radius ``R``: each limb ``(ρ, θ)`` is the trace of a
    plane through the optical centre tangent to the cylinder, with unit normal
    ``ñ = (cos θ, sin θ, -ρ)/sqrt(1 + ρ²)`` (the features' orientation puts the
    axis on the positive side of both). With ``S = ñ1 + ñ2``: the distance to
    the axis is ``d = 2R/|S|``, the nearest axis point ``X0 = d S/|S|``, and
    ``(A, B, C)/D = -X0/(d² - R²)``. Exact.
  - points of a known point set (a point feature, or the moments of the set):
    the fronto-parallel scale ``Ẑ = sqrt(Σ|Pi - Pj|² / Σ|pi - pj|²)`` over the
    pairs of detected dots (3-D distances in the object frame, image distances
    in normalized units); ``1/Ẑ`` for a point, plane ``(0, 0, 1/Ẑ)`` for the
    moments. Exact when the set is parallel to the image plane, otherwise a
    mean depth. Needs at least two detected dots.
  - a line has no apparent size: :class:`~redservo.errors.ConfigurationError`.

* ``"true"``: the exact parameters from the true pose (for comparison only:
  no real sensor has them).
* ``"pose"``: for a point or moment feature, the parameters at the pose of its point set
  estimated from the detected dots by PnP (:func:`redservo.vision.pnp.pose_inv_depth`,
  warm-started at the previous frame's pose; at least four dots): a measured 1/Z per point
  and the measured object plane, as the ideal sensor gives them; the other features (and a
  frame without a pose) keep the last parameters, the desired ones at first.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, get_args

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_matrix, as_vector
from redservo.errors import ConfigurationError, GeometryError
from redservo.features.kinds import feature_adapter
from redservo.features.sphere import sphere_moments_from_area

if TYPE_CHECKING:  # pragma: no cover
    from redservo.features.base import Feature
    from redservo.features.line import CylinderFeature
    from redservo.features.moments import MomentFeatures
    from redservo.features.point import PointFeature
    from redservo.features.sphere import SphereFeature

__all__ = [
    "DEPTH_POLICIES",
    "DepthPolicy",
    "cylinder_depth",
    "cylinder_plane",
    "estimate_inv_depth",
    "moments_depth",
    "point_depth",
    "point_set_depth",
    "set_depth",
    "sphere_depth",
    "sphere_plane",
]

DepthPolicy = Literal["desired", "estimated", "true", "pose"]
DEPTH_POLICIES: tuple[str, ...] = get_args(DepthPolicy)


def sphere_plane(s_ellipse: ArrayLike, radius: float) -> FloatArray:
    """``(A, B, C)`` (3,) of a sphere of ``radius`` (m) from its ellipse ``(xc, yc, n20, n11, n02)``.

    Raises:
        GeometryError: a degenerate ellipse (non-positive minor axis).
    """
    xc, yc, n20, n11, n02 = as_vector(s_ellipse, "s_ellipse", 5)
    b2 = float(np.linalg.eigvalsh(4.0 * np.array([[n20, n11], [n11, n02]]))[0])
    if not b2 > 0.0:
        raise GeometryError(f"the sphere's ellipse is degenerate (minor axis² {b2:.3g})")
    r2 = float(radius) ** 2
    m = r2 / b2
    Z = float(np.sqrt(m + r2))
    X0 = np.array([xc * m / Z, yc * m / Z, Z])
    return np.asarray(X0 / (float(X0 @ X0) - r2), dtype=float)


def cylinder_plane(s_cylinder: ArrayLike, radius: float) -> FloatArray:
    """``(A, B, C)/D`` (3,) of a cylinder of ``radius`` (m) from its limbs ``(ρ1, θ1, ρ2, θ2)``.

    Raises:
        GeometryError: parallel limb planes (the axis at infinity).
    """
    r1, t1, r2, t2 = as_vector(s_cylinder, "s_cylinder", 4)
    n1 = np.array([np.cos(t1), np.sin(t1), -r1]) / np.sqrt(1.0 + r1 * r1)
    n2 = np.array([np.cos(t2), np.sin(t2), -r2]) / np.sqrt(1.0 + r2 * r2)
    S = n1 + n2
    norm = float(np.linalg.norm(S))
    if norm < 1e-9:
        raise GeometryError("the cylinder's limb planes are parallel; its distance is unknown")
    d = 2.0 * float(radius) / norm
    X0 = d * S / norm
    return np.asarray(-X0 / (d * d - float(radius) ** 2), dtype=float)


def point_set_depth(points_o: ArrayLike, xy: ArrayLike) -> float:
    """Fronto-parallel depth ``Ẑ`` (m) of a point set from its dots (module docstring).

    Args:
        points_o: (N, 3) the set's points (object frame, m).
        xy: (N, 2) their detected images (normalized); rows with NaN are skipped.

    Raises:
        GeometryError: fewer than two usable dots, or coincident images.
    """
    P = as_matrix(points_o, "points_o", None, 3)
    p = np.asarray(xy, dtype=float).reshape(-1, 2)
    ok = np.isfinite(p).all(axis=1)
    P, p = P[ok], p[ok]
    if P.shape[0] < 2:
        raise GeometryError(
            "a depth from apparent size needs at least two detected dots of the point set"
        )
    i, j = np.triu_indices(P.shape[0], 1)
    num = float(np.sum((P[i] - P[j]) ** 2))
    den = float(np.sum((p[i] - p[j]) ** 2))
    if den <= 0.0 or num <= 0.0:
        raise GeometryError("the dots coincide; the apparent size is zero")
    return float(np.sqrt(num / den))


def estimate_inv_depth(
    feature: Feature,
    s: FloatArray,
    *,
    set_points: ArrayLike | None = None,
    set_xy: ArrayLike | None = None,
) -> FloatArray:
    """Inverse-depth parameters of ``feature`` estimated from its measured value ``s``.

    Args:
        feature: The task term's feature.
        s: Its measured value.
        set_points: For a point or moment feature, the (N, 3) points of its point set.
        set_xy: For a point or moment feature, the (N, 2) detected dots (normalized).

    Raises:
        ConfigurationError: the feature kind has no known size (a line).
        GeometryError: the estimate is impossible here (too few dots, degenerate image).
    """
    estimate = feature_adapter(feature, "depth")
    if estimate is None:
        raise ConfigurationError(
            f"depth='estimated' is not available for {type(feature).__name__} (no known size); "
            "use depth='desired' or 'true'"
        )
    out: FloatArray = estimate(feature, s, set_points=set_points, set_xy=set_xy)
    return out


def sphere_depth(
    feature: SphereFeature,
    s: FloatArray,
    *,
    set_points: ArrayLike | None = None,
    set_xy: ArrayLike | None = None,
) -> FloatArray:
    """A sphere's ``(A, B, C)`` from its ellipse (:func:`sphere_plane`), either variant."""
    sv = np.asarray(s, dtype=float)
    if feature.variant != "moments":
        n20, n11, n02 = sphere_moments_from_area(sv[0], sv[1], sv[2])
        sv = np.array([sv[0], sv[1], n20, n11, n02])
    return sphere_plane(sv, feature.radius)


def cylinder_depth(
    feature: CylinderFeature,
    s: FloatArray,
    *,
    set_points: ArrayLike | None = None,
    set_xy: ArrayLike | None = None,
) -> FloatArray:
    """A cylinder's ``(A, B, C)/D`` from its limbs (:func:`cylinder_plane`)."""
    return cylinder_plane(s, feature.radius)


def set_depth(set_points: ArrayLike | None, set_xy: ArrayLike | None) -> float:
    """``Ẑ`` (m), the fronto-parallel depth of a point set from its detected dots
    (:func:`point_set_depth`), for a feature measured on them.

    Raises:
        ConfigurationError: the point set's dots are not given.
    """
    if set_points is None or set_xy is None:
        raise ConfigurationError(
            "depth='estimated' for a point or moment feature needs the point set's dots"
        )
    return point_set_depth(set_points, set_xy)


def point_depth(
    feature: PointFeature,
    s: FloatArray,
    *,
    set_points: ArrayLike | None = None,
    set_xy: ArrayLike | None = None,
) -> FloatArray:
    """A point's ``1/Ẑ`` (1/m; :func:`set_depth`)."""
    return np.array([1.0 / set_depth(set_points, set_xy)])


def moments_depth(
    feature: MomentFeatures,
    s: FloatArray,
    *,
    set_points: ArrayLike | None = None,
    set_xy: ArrayLike | None = None,
) -> FloatArray:
    """The moments' plane ``(0, 0, 1/Ẑ)`` (1/m; :func:`set_depth`)."""
    return np.array([0.0, 0.0, 1.0 / set_depth(set_points, set_xy)])
