"""Visual features and their interaction matrices.

Every feature subclasses :class:`Feature`: it holds its object's geometry in the
object frame, ``measure(cMo)`` returns ``Measurement(s, inv_depth)`` and
``interaction(s, inv_depth)`` the matrix ``L_s`` (k, 6) with ``ṡ = L_s v_c``
(docs/formulas.md §1). :func:`make_feature` builds one by kind name.
"""

from __future__ import annotations

from typing import Any

from redservo.errors import ConfigurationError, UnknownNameError
from redservo.features.base import Feature, Measurement, wrap_angle
from redservo.features.kinds import FeatureKind, feature_kinds, object_adapter, register_feature
from redservo.features.line import (
    CylinderFeature,
    CylinderProjection,
    LineFeature,
    LineProjection,
    cylinder_interaction,
    cylinder_lines,
    line_interaction,
    project_line,
)
from redservo.features.moments import (
    ROTATION_FEATURES,
    ImageMoments,
    MomentFeatures,
    MomentTarget,
    RotationFeatures,
    centred_moment_interaction,
    centroid_interaction,
    image_moments,
    moment_features,
    moment_features_interaction,
    object_plane,
    rotation_invariants,
)
from redservo.features.point import PointFeature, point_interaction, project_point
from redservo.features.pose import LogDepth, PoseThetaU, PoseTranslation, thetau_interaction
from redservo.features.sphere import (
    SPHERE_VARIANTS,
    SphereFeature,
    SphereImage,
    SphereVariant,
    ellipse_moment_interaction,
    sphere_ellipse,
    sphere_interaction,
    sphere_moments_from_area,
    sphere_paper_interaction,
)

__all__ = [
    "FEATURES",
    "ROTATION_FEATURES",
    "SPHERE_VARIANTS",
    "CylinderFeature",
    "CylinderProjection",
    "Feature",
    "FeatureKind",
    "ImageMoments",
    "LineFeature",
    "LineProjection",
    "LogDepth",
    "Measurement",
    "MomentFeatures",
    "MomentTarget",
    "PointFeature",
    "PoseThetaU",
    "PoseTranslation",
    "RotationFeatures",
    "SphereFeature",
    "SphereImage",
    "SphereVariant",
    "centred_moment_interaction",
    "centroid_interaction",
    "cylinder_interaction",
    "cylinder_lines",
    "ellipse_moment_interaction",
    "feature_class",
    "feature_kinds",
    "image_moments",
    "line_interaction",
    "make_feature",
    "moment_features",
    "moment_features_interaction",
    "object_adapter",
    "object_plane",
    "point_interaction",
    "project_line",
    "project_point",
    "register_feature",
    "rotation_invariants",
    "sphere_ellipse",
    "sphere_interaction",
    "sphere_moments_from_area",
    "sphere_paper_interaction",
    "thetau_interaction",
    "wrap_angle",
]

FEATURES: tuple[str, ...] = tuple(feature_kinds())
"""Feature kinds accepted by :func:`make_feature` (the shipped ones; the declared kinds are
:func:`redservo.features.kinds.feature_kinds`)."""


def feature_class(kind: str) -> type[Feature]:
    """Return the class of feature ``kind``; :class:`UnknownNameError` lists the known kinds."""
    kinds = feature_kinds()
    if kind not in kinds:
        raise UnknownNameError(f"unknown feature kind {kind!r}; allowed: {', '.join(kinds)}")
    cls: type[Feature] = kinds[kind].feature
    return cls


def make_feature(kind: str, **options: Any) -> Feature:
    """Build a feature by kind name, passing ``options`` to its constructor.

    Examples: ``make_feature("sphere", radius=0.1, variant="paper")``,
    ``make_feature("cylinder", radius=0.05, axis=(0, 1, 0))``,
    ``make_feature("pose_thetau", variant="cdRc", desired=cdMo)``.

    Raises:
        UnknownNameError: unknown ``kind``.
        ConfigurationError: options the constructor does not accept.
        GeometryError, ShapeError: invalid geometry (from the constructor).
    """
    cls = feature_class(kind)
    try:
        return cls(**options)
    except TypeError as exc:
        raise ConfigurationError(f"invalid options for feature {kind!r}: {exc}") from None
