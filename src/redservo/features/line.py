"""Straight lines ``s = (ρ, θ)`` and cylinders as their two limb lines (docs/formulas.md §3.2).

An image line is ``x cos θ + y sin θ - ρ = 0`` (normalized coordinates). Its
interaction matrix (Espiau, Chaumette & Rives 1992; Chaumette 1994, the
reference [10] of CM01 for the cylinder) needs any plane ``A X + B Y + C Z + D = 0``
containing the 3-D line and not the optical centre; the inverse-depth
parameters are ``(A, B, C)/D`` (3,).

Decisions:
    * Orientation: the image line of a 3-D line through ``P0`` with direction
      ``u`` uses the normal ``n = P0 x u`` of its interpretation plane:
      ``θ = atan2(n_y, n_x)``, ``ρ = -n_z / |(n_x, n_y)|``. The sign of ``n``
      follows the object's direction ``u``, so ``(ρ, θ)`` never jumps to the
      equivalent ``(-ρ, θ + π)``.
    * ``θ`` is reported in (-π, π]; errors are wrapped by ``Feature.error``
      (the cylinder's desired ``θ2 = π`` sits on the branch cut).
    * Plane for a line: ``n = u x (P0 x u)`` (the component of ``P0``
      orthogonal to ``u``), ``D = -|n|²``: the plane through the line
      orthogonal to the interpretation plane, well conditioned whenever the
      line misses the optical centre. Any plane of the pencil gives the same
      matrix (docs/formulas.md §3.2).
    * Plane for a cylinder: the polar plane of the optical centre,
      ``(A, B, C) = -X0⊥``, ``D = |X0⊥|² - R²`` with ``X0⊥`` the axis point nearest
      the optical centre; it contains both contour generators and is exact for
      both limbs although they slide on the surface (docs/formulas.md §3.2).
    * A line (or limb) parallel to the image plane and at or behind it is
      rejected, as is a line through the optical centre (it images to a point)
      or lying in the plane ``Z = 0`` (it images to the line at infinity).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform, as_vector
from redservo.errors import GeometryError
from redservo.features.base import Feature, Measurement
from redservo.features.kinds import FeatureKind
from redservo.kernels import lazy

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import features as _K
else:
    _K = lazy("features")
_BEHIND, _ZERO_AXIS, _THROUGH, _PARALLEL, _INFINITY, _INSIDE = 1, 2, 3, 4, 5, 6
"""Codes of :mod:`redservo.kernels.features`."""

__all__ = [
    "CylinderFeature",
    "CylinderProjection",
    "LineFeature",
    "LineProjection",
    "cylinder_interaction",
    "cylinder_lines",
    "line_interaction",
    "project_line",
]

_PARALLEL_TOL = 1e-9
"""|u_z| below this counts as parallel to the image plane; relative tolerance for degeneracy
(the value :mod:`redservo.kernels.features` uses)."""


class LineProjection(NamedTuple):
    """Image of a 3-D line."""

    rho: float
    """Signed distance of the image line to the principal point (normalized units)."""
    theta: float
    """Angle (rad) of the image line's normal, in (-π, π]."""
    plane: FloatArray
    """(3,) ``(A, B, C)/D`` of a plane containing the line (1/m)."""


class CylinderProjection(NamedTuple):
    """Image of a cylinder: its two limb lines."""

    s: FloatArray
    """(4,) ``(ρ1, θ1, ρ2, θ2)``, angles in (-π, π]."""
    plane: FloatArray
    """(3,) ``(A, B, C)/D`` of the polar plane of the optical centre (1/m)."""


def line_interaction(rho: float, theta: float, plane: ArrayLike) -> FloatArray:
    """Interaction matrix (2, 6) of an image line ``(ρ, θ)`` (docs/formulas.md §3.2).

    With ``(A, B, C)/D`` = ``plane``::

        λ_ρ = (A ρ cos θ + B ρ sin θ + C)/D,   λ_θ = (A sin θ - B cos θ)/D
        L_ρ = [λ_ρ cos θ, λ_ρ sin θ, -λ_ρ ρ, (1 + ρ²) sin θ, -(1 + ρ²) cos θ, 0]
        L_θ = [λ_θ cos θ, λ_θ sin θ, -λ_θ ρ, -ρ cos θ, -ρ sin θ, -1]

    Args:
        rho: Line parameter ρ (normalized units).
        theta: Line angle θ (rad).
        plane: (3,) ``(A, B, C)/D`` of any plane through the 3-D line, not through
            the optical centre (1/m).
    """
    P = np.ascontiguousarray(plane, dtype=np.float64)
    return np.asarray(_K.line_interaction(float(rho), float(theta), P))


def project_line(point_c: ArrayLike, direction_c: ArrayLike) -> LineProjection:
    """Project the 3-D line through ``point_c`` along ``direction_c`` (camera frame, m).

    Raises:
        GeometryError: zero-length direction; the line passes through the optical
            centre; it lies in the plane Z = 0; or it is parallel to the image plane
            at or behind it.
    """
    P0 = as_vector(point_c, "point_c", 3)
    u = as_vector(direction_c, "direction_c", 3)
    rho, theta, plane, code, value = _K.project_line(
        np.ascontiguousarray(P0), np.ascontiguousarray(u)
    )
    if code == _ZERO_AXIS:
        raise GeometryError(f"zero-length axis: the line direction must be non-zero, got {u}")
    if code == _THROUGH:
        raise GeometryError(
            f"the line passes through the optical centre (distance {value:.3g} m) "
            "and images to a point"
        )
    if code == _PARALLEL:
        raise GeometryError(
            f"the line is parallel to the image plane at or behind the camera (Z = {value:.6g} m)"
        )
    if code == _INFINITY:
        raise _at_infinity("the line")
    return LineProjection(float(rho), float(theta), plane)


def _at_infinity(what: str) -> GeometryError:
    return GeometryError(
        f"{what} lies in the camera plane Z = 0 and images to the line at infinity"
    )


def cylinder_lines(radius: float, axis_c: ArrayLike, point_c: ArrayLike) -> CylinderProjection:
    """Project a cylinder to its two limb lines (docs/formulas.md §3.2, steps 1-4).

    Args:
        radius: Cylinder radius R (m), > 0.
        axis_c: (3,) axis direction ``a`` in the camera frame (any non-zero length).
        point_c: (3,) a point ``X0`` of the axis in the camera frame (m).

    Returns:
        ``s = (ρ1, θ1, ρ2, θ2)`` with limb 1 from ``n1 = R s X0 - w`` and limb 2
        from ``n2 = R s X0 + w`` (``w = X0 x a``, ``s = 1/sqrt(|X0|² - R²)``,
        ``X0`` reduced to the axis point nearest the optical centre), and the polar
        plane ``(A, B, C)/D = -X0/(|X0|² - R²)``.

    Raises:
        GeometryError: non-positive radius, zero-length axis, camera inside or on
            the cylinder, a limb in the plane Z = 0, or a limb parallel to the
            image plane at or behind it.
    """
    R = float(radius)
    if not (np.isfinite(R) and R > 0.0):
        raise GeometryError(f"cylinder radius must be positive and finite (m), got {radius!r}")
    a = as_vector(axis_c, "axis_c", 3)
    X0 = as_vector(point_c, "point_c", 3)
    s, plane, code, value = _K.cylinder_lines(R, np.ascontiguousarray(a), np.ascontiguousarray(X0))
    if code == _ZERO_AXIS:
        raise GeometryError(f"zero-length axis: the cylinder axis must be non-zero, got {a}")
    if code == _INSIDE:
        raise GeometryError(
            f"the camera is inside or on the cylinder (distance to the axis {value:.6g} m, "
            f"radius {R:.6g} m); it must be outside"
        )
    if code == _PARALLEL:
        raise GeometryError(
            "a limb of the cylinder is parallel to the image plane at or behind "
            f"the camera (Z = {value:.6g} m)"
        )
    if code == _INFINITY:
        raise _at_infinity(f"limb {int(value)} of the cylinder")
    return CylinderProjection(s, plane)


def cylinder_interaction(s: ArrayLike, plane: ArrayLike) -> FloatArray:
    """Interaction matrix (4, 6) of ``(ρ1, θ1, ρ2, θ2)``: both limbs with the polar ``plane`` (3,)."""
    c = np.ascontiguousarray
    return np.asarray(_K.cylinder_interaction(c(s, dtype=np.float64), c(plane, dtype=np.float64)))


class LineFeature(Feature):
    """The image ``s = (ρ, θ)`` of a straight line fixed in the object frame.

    ``inv_depth = (A, B, C)/D`` (3,) of the plane described in the module docstring.

    Args:
        point: (3,) a point of the line, object frame (m).
        direction: (3,) its direction, object frame (any non-zero length).
    """

    names = ("rho", "theta")
    angular = (False, True)

    def __init__(self, point: ArrayLike, direction: ArrayLike) -> None:
        self.point = as_vector(point, "point", 3)
        u = as_vector(direction, "direction", 3)
        nu = float(np.linalg.norm(u))
        if nu < 1e-12:
            raise GeometryError(f"zero-length axis: the line direction must be non-zero, got {u}")
        self.direction = u / nu

    def measure(self, cMo: FloatArray) -> Measurement:
        return self._measure_trusted(as_transform(cMo, "cMo"))

    def _measure_trusted(self, cMo: FloatArray) -> Measurement:
        R, t = cMo[:3, :3], cMo[:3, 3]
        proj = project_line(R @ self.point + t, R @ self.direction)
        return Measurement(np.array([proj.rho, proj.theta]), proj.plane)

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        rho, theta = as_vector(s, "s", 2)
        return line_interaction(float(rho), float(theta), as_vector(inv_depth, "inv_depth", 3))

    def __repr__(self) -> str:
        return f"LineFeature(point={self.point.tolist()}, direction={self.direction.tolist()})"


class CylinderFeature(Feature):
    """The two limb lines ``s = (ρ1, θ1, ρ2, θ2)`` of a cylinder fixed in the object frame.

    ``inv_depth = (A, B, C)/D`` (3,) of the polar plane (module docstring). With
    the axis along the camera's y axis and centred (``a = (0, 1, 0)``,
    ``X0 = (0, 0, Z*)``), ``s* = (-R/sqrt(Z*² - R²), 0, -R/sqrt(Z*² - R²), π)``,
    CM01's "vertical and centred" task; flipping ``a`` swaps the limb labels.

    Args:
        radius: Radius R (m), > 0.
        axis: (3,) axis direction in the object frame (any non-zero length).
        point: (3,) a point of the axis in the object frame (m), default the origin.
    """

    names = ("rho1", "theta1", "rho2", "theta2")
    angular = (False, True, False, True)

    def __init__(self, radius: float, axis: ArrayLike, point: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        r = float(radius)
        if not (np.isfinite(r) and r > 0.0):
            raise GeometryError(f"cylinder radius must be positive and finite (m), got {radius!r}")
        self.radius = r
        a = as_vector(axis, "axis", 3)
        na = float(np.linalg.norm(a))
        if na < 1e-12:
            raise GeometryError(f"zero-length axis: the cylinder axis must be non-zero, got {a}")
        self.axis = a / na
        self.point = as_vector(point, "point", 3)

    def measure(self, cMo: FloatArray) -> Measurement:
        return self._measure_trusted(as_transform(cMo, "cMo"))

    def _measure_trusted(self, cMo: FloatArray) -> Measurement:
        R, t = cMo[:3, :3], cMo[:3, 3]
        proj = cylinder_lines(self.radius, R @ self.axis, R @ self.point + t)
        return Measurement(proj.s, proj.plane)

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        return cylinder_interaction(as_vector(s, "s", 4), as_vector(inv_depth, "inv_depth", 3))

    def __repr__(self) -> str:
        return (
            f"CylinderFeature(radius={self.radius}, axis={self.axis.tolist()}, "
            f"point={self.point.tolist()})"
        )


LINE_KIND = FeatureKind(
    "line",
    LineFeature,
    schema="redservo.schema.features:LineSpec",
    obj="redservo.scene:Line",
    render="redservo.vision.shapes:_line_layer",
    mujoco="redservo.physics.scenes:line_geoms",
    viewer="redservo.viewer.playback:line_primitive",
    image_term="redservo.vision.measure:line_term",
    measure_image="redservo.vision.measure:measure_image_lines",
    measure_mujoco="redservo.physics.camera:measure_mujoco_line",
    draw="redservo.vision.overlay:draw_line_term",
)
"""The line kind and the adapters of its lines (:mod:`redservo.features.kinds`)."""

CYLINDER_KIND = FeatureKind(
    "cylinder",
    CylinderFeature,
    schema="redservo.schema.features:CylinderSpec",
    obj="redservo.scene:Cylinder",
    render="redservo.vision.shapes:_cylinder_layer",
    mujoco="redservo.physics.scenes:cylinder_geoms",
    viewer="redservo.viewer.playback:cylinder_primitive",
    image_term="redservo.vision.measure:shape_term",
    measure_image="redservo.vision.measure:measure_image_lines",
    measure_mujoco="redservo.physics.camera:measure_mujoco_cylinder",
    depth="redservo.vision.depth:cylinder_depth",
    draw="redservo.vision.overlay:draw_cylinder",
)
"""The cylinder kind and the adapters of its cylinders (:mod:`redservo.features.kinds`)."""
