"""Visual features and their interaction matrices.

Every feature subclasses :class:`Feature`: it holds its object's geometry in the
object frame, ``measure(cMo)`` returns ``Measurement(s, inv_depth)`` and
``interaction(s, inv_depth)`` the matrix ``L_s`` (k, 6) with ``ṡ = L_s v_c``
(literature.md §0). :func:`make_feature` builds one by kind name.
"""

from __future__ import annotations

from redservo.features.base import Feature, Measurement, wrap_angle
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
from redservo.features.point import PointFeature, point_interaction, project_point
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
    "SPHERE_VARIANTS",
    "CylinderFeature",
    "CylinderProjection",
    "Feature",
    "LineFeature",
    "LineProjection",
    "Measurement",
    "PointFeature",
    "SphereFeature",
    "SphereImage",
    "SphereVariant",
    "cylinder_interaction",
    "cylinder_lines",
    "ellipse_moment_interaction",
    "line_interaction",
    "point_interaction",
    "project_line",
    "project_point",
    "sphere_ellipse",
    "sphere_interaction",
    "sphere_moments_from_area",
    "sphere_paper_interaction",
    "wrap_angle",
]
