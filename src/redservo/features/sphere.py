"""A sphere seen as an ellipse: centre, area and second-order moments (docs/formulas.md §3.3).

A sphere of radius ``r`` and centre ``X0`` (camera frame) images to an ellipse
with centre ``(xc, yc)``, area ``a`` and normalized centred moments
``n_ij = μ_ij / a``. The inverse-depth parameters are the polar plane of the
optical centre, ``1/Z = A x + B y + C`` with ``(A, B, C) = X0/(|X0|² - r²)``.
The general interaction matrices come from Chaumette 2004 (T-RO 20(4): eq. 14
for the centre, eq. 26 for ``n_ij``, and the area formula), as transcribed in
docs/formulas.md §3.3.

Variants of :class:`SphereFeature`:

* ``"exact"`` (default): ``s = (xc, yc, a)`` with the exact ``L_xc, L_yc, L_a``.
  ``L_xc`` and ``L_yc`` need ``n20, n11, n02``; a sphere's ellipse has only
  three degrees of freedom, so these follow from ``s`` alone
  (:func:`sphere_moments_from_area`) and the matrix stays exact whatever
  inverse-depth parameters the caller substitutes.
* ``"paper"``: same ``s``, with CM01 eq. 27 (the matrix printed for the desired
  on-axis pose) evaluated at the current value. Eq. 27 is written with the image
  radius R and the centre distance ``z_d``; at a general pose we take
  ``R² = a/π`` (so that ``πR² = a``) and ``1/z_d = C/(1 + R²)``, which is exactly
  ``1/z_d`` on the optical axis (there ``C = z_d/(z_d² - r²) = (1 + R²)/z_d``).
  It keeps eq. 27's approximations (``-1/z_d`` for ``-(1 + R²)/z_d``, and
  ``πR²/z_d`` for ``2πR²(1 + R²)/z_d`` on the area row, docs/formulas.md §3.3 and
  D.3 item 11) and exists only so that the paper can be replayed as printed.
  It is *not* the derivative of ``s``.
* ``"moments"``: ``s = (xc, yc, n20, n11, n02)`` with the exact matrices.

Validity: the camera must be outside the sphere and the whole sphere in front
of the camera plane (``Z0 > r``), otherwise the contour is not an ellipse.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, NamedTuple, get_args

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform, as_vector
from redservo.errors import ConfigurationError, GeometryError
from redservo.features.base import Feature, Measurement
from redservo.features.kinds import FeatureKind
from redservo.kernels import lazy

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import features as _K
else:
    _K = lazy("features")
_INSIDE, _NOT_IN_FRONT = 6, 7
"""Codes of :func:`redservo.kernels.features.sphere_ellipse`."""

__all__ = [
    "SPHERE_VARIANTS",
    "SphereFeature",
    "SphereImage",
    "SphereVariant",
    "ellipse_moment_interaction",
    "sphere_ellipse",
    "sphere_interaction",
    "sphere_moments_from_area",
    "sphere_paper_interaction",
]

SphereVariant = Literal["exact", "paper", "moments"]
SPHERE_VARIANTS: tuple[str, ...] = get_args(SphereVariant)


class SphereImage(NamedTuple):
    """The ellipse a sphere projects to (normalized image units)."""

    xc: float
    """Centre abscissa."""
    yc: float
    """Centre ordinate."""
    area: float
    """Area ``a = π a_ b_`` of the ellipse."""
    n20: float
    """Normalized centred moment ``μ20 / a``."""
    n11: float
    """Normalized centred moment ``μ11 / a``."""
    n02: float
    """Normalized centred moment ``μ02 / a``."""
    plane: FloatArray
    """(3,) ``(A, B, C)`` of the limb plane, ``1/Z = A x + B y + C`` (1/m)."""


def sphere_ellipse(radius: float, center_c: ArrayLike) -> SphereImage:
    """Project a sphere of ``radius`` (m) centred at ``center_c`` (3,) in the camera frame.

    With ``m = Z0² - r²`` (docs/formulas.md §3.3):
    ``xc = X0 Z0/m``, ``yc = Y0 Z0/m``, ``a = π r² sqrt(|X0|² - r²)/m^(3/2)``,
    ``n20 = r²(m + X0²)/(4 m²)``, ``n02 = r²(m + Y0²)/(4 m²)``, ``n11 = r² X0 Y0/(4 m²)``
    (the semi-axis form of A3 with ``a_² - b_² = r²(X0² + Y0²)/m²``, which needs
    no angle and stays smooth on the optical axis).

    Raises:
        GeometryError: non-positive radius, camera inside or on the sphere, or the
            sphere not entirely in front of the camera plane.
    """
    r = float(radius)
    if not (np.isfinite(r) and r > 0.0):
        raise GeometryError(f"sphere radius must be positive and finite (m), got {radius!r}")
    X, Y, Z = as_vector(center_c, "center_c", 3)
    xc, yc, area, n20, n11, n02, plane, code, value = _K.sphere_ellipse(
        r, float(X), float(Y), float(Z)
    )
    if code == _INSIDE:
        raise GeometryError(
            f"the camera is inside or on the sphere (centre distance {value:.6g} m, "
            f"radius {r:.6g} m); it must be outside"
        )
    if code == _NOT_IN_FRONT:
        raise GeometryError(
            f"the sphere is not entirely in front of the camera (centre depth {value:.6g} m, "
            f"radius {r:.6g} m); its image is an ellipse only when Z0 > r"
        )
    return SphereImage(
        xc=float(xc),
        yc=float(yc),
        area=float(area),
        n20=float(n20),
        n11=float(n11),
        n02=float(n02),
        plane=plane,
    )


def sphere_moments_from_area(xc: float, yc: float, area: float) -> tuple[float, float, float]:
    """Return ``(n20, n11, n02)`` of a sphere's ellipse from its centre and area.

    A sphere's image has three degrees of freedom. With ``β = b_²`` (squared minor
    semi-axis) and ``ρ² = xc² + yc²``, the ellipse of docs/formulas.md §3.3 satisfies
    ``a_² = β (1 + ρ²/(1 + β))`` and ``(a/π)² = a_² β``, i.e. the cubic
    ``β³ + (1 + ρ²) β² - (a/π)² β - (a/π)² = 0``, which has exactly one positive
    root (Descartes). Newton's method from ``β = a/π`` (an upper bound; the cubic
    is convex for β > 0) converges monotonically. Then
    ``n20 = β (1 + xc²/(1 + β))/4``, ``n02 = β (1 + yc²/(1 + β))/4``,
    ``n11 = β xc yc/(4 (1 + β))``.

    Args:
        xc: Ellipse centre abscissa (normalized).
        yc: Ellipse centre ordinate (normalized).
        area: Ellipse area (normalized units²); its sign is ignored.
    """
    n20, n11, n02 = _K.sphere_moments_from_area(float(xc), float(yc), float(area))
    return float(n20), float(n11), float(n02)


def sphere_interaction(s: ArrayLike, plane: ArrayLike) -> FloatArray:
    """Exact interaction matrix (3, 6) of ``s = (xc, yc, a)`` (docs/formulas.md §3.3).

    ``L_a = [-a A, -a B, a (3/Zg - C), 3 a yc, -3 a xc, 0]`` with
    ``1/Zg = A xc + B yc + C``; the centre rows use the moments of
    :func:`sphere_moments_from_area`.

    Args:
        s: (3,) ``(xc, yc, a)``.
        plane: (3,) ``(A, B, C)`` (1/m).
    """
    return np.asarray(_K.sphere_interaction(_vec(s), _vec(plane)))


def _vec(value: ArrayLike) -> FloatArray:
    return np.ascontiguousarray(value, dtype=np.float64)


def sphere_paper_interaction(s: ArrayLike, plane: ArrayLike) -> FloatArray:
    """CM01 eq. 27 (3, 6) evaluated at ``s = (xc, yc, a)`` (see the module docstring).

    ``R² = a/π``, ``1/z_d = C/(1 + R²)``::

        [[-1/z_d, 0, 0, 0, -(1 + R²), 0],
         [0, -1/z_d, 0, 1 + R², 0, 0],
         [0, 0, π R²/z_d, 0, 0, 0]]
    """
    return np.asarray(_K.sphere_paper_interaction(_vec(s), _vec(plane)))


def ellipse_moment_interaction(s: ArrayLike, plane: ArrayLike) -> FloatArray:
    """Exact interaction matrix (5, 6) of ``s = (xc, yc, n20, n11, n02)`` of an ellipse.

    Chaumette 2004 eqs. 14 and 26 for a region on the plane ``1/Z = A x + B y + C``
    (docs/formulas.md §3.3; ``1/Zg = A xc + B yc + C``)::

        L_n20 = [-2(A n20 + B n11), 0, 2((1/Zg + A xc) n20 + B xc n11),
                 2(yc n20 + xc n11), -4 n20 xc, 2 n11]
        L_n11 = [-A n11 - B n02, -A n20 - B n11, A yc n20 + (3/Zg - C) n11 + B xc n02,
                 3 yc n11 + xc n02, -yc n20 - 3 xc n11, n02 - n20]
        L_n02 = [0, -2(A n11 + B n02), 2((1/Zg + B yc) n02 + A yc n11),
                 4 yc n02, -2(yc n11 + xc n02), -2 n11]
    """
    return np.asarray(_K.ellipse_moment_interaction(_vec(s), _vec(plane)))


class SphereFeature(Feature):
    """The ellipse of a sphere fixed in the object frame (variants in the module docstring).

    ``inv_depth = (A, B, C)`` (3,), the limb plane ``1/Z = A x + B y + C``.

    Args:
        radius: Sphere radius r (m), > 0.
        center: (3,) centre in the object frame (m), default the origin.
        variant: ``"exact"``, ``"paper"`` or ``"moments"`` (keyword-only).
    """

    def __init__(
        self,
        radius: float,
        center: ArrayLike = (0.0, 0.0, 0.0),
        *,
        variant: SphereVariant = "exact",
    ) -> None:
        r = float(radius)
        if not (np.isfinite(r) and r > 0.0):
            raise GeometryError(f"sphere radius must be positive and finite (m), got {radius!r}")
        if variant not in SPHERE_VARIANTS:
            raise ConfigurationError(
                f"unknown sphere variant {variant!r}; allowed: {', '.join(SPHERE_VARIANTS)}"
            )
        self.radius = r
        self.center = as_vector(center, "center", 3)
        self.variant: SphereVariant = variant
        if variant == "moments":
            self.names = ("xc", "yc", "n20", "n11", "n02")
        else:
            self.names = ("xc", "yc", "a")
        self.angular = (False,) * len(self.names)

    def measure(self, cMo: FloatArray) -> Measurement:
        return self._measure_trusted(as_transform(cMo, "cMo"))

    def _measure_trusted(self, cMo: FloatArray) -> Measurement:
        T = cMo
        img = sphere_ellipse(self.radius, T[:3, :3] @ self.center + T[:3, 3])
        if self.variant == "moments":
            s = np.array([img.xc, img.yc, img.n20, img.n11, img.n02])
        else:
            s = np.array([img.xc, img.yc, img.area])
        return Measurement(s, img.plane)

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        sv = as_vector(s, "s", self.size)
        plane = as_vector(inv_depth, "inv_depth", 3)
        if self.variant == "moments":
            return ellipse_moment_interaction(sv, plane)
        if self.variant == "paper":
            return sphere_paper_interaction(sv, plane)
        return sphere_interaction(sv, plane)

    def __repr__(self) -> str:
        return (
            f"SphereFeature(radius={self.radius}, center={self.center.tolist()}, "
            f"variant={self.variant!r})"
        )


KIND = FeatureKind(
    "sphere",
    SphereFeature,
    schema="redservo.schema.features:SphereSpec",
    obj="redservo.scene:Sphere",
    render="redservo.vision.shapes:_sphere_layer",
    mujoco="redservo.physics.scenes:sphere_geoms",
    viewer="redservo.viewer.playback:sphere_primitive",
    image_term="redservo.vision.measure:shape_term",
    measure_image="redservo.vision.measure:measure_image_sphere",
    measure_mujoco="redservo.physics.camera:measure_mujoco_sphere",
    depth="redservo.vision.depth:sphere_depth",
    draw="redservo.vision.overlay:draw_sphere",
)
"""The sphere kind and the adapters of its spheres (:mod:`redservo.features.kinds`)."""
