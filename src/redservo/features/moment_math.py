"""Moment computations behind :class:`~redservo.features.moments.MomentFeatures`: image
moments, the object plane, the six features and their interaction matrices (kernels of
:mod:`redservo.kernels.moments` and :mod:`redservo.kernels.moment_interaction`). Definitions and decisions: the docstring of
:mod:`redservo.features.moments`, which re-exports every public name here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal, NamedTuple, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray, as_matrix
from redservo.errors import ConfigurationError, GeometryError
from redservo.kernels import lazy

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import moment_interaction as _KL
    from redservo.kernels import moments as _K
else:
    _K = lazy("moments")
    _KL = lazy("moment_interaction")
_KIND = {"c4c6": 0, "pxpy": 1, "sxsy": 2}
(
    _BEHIND,
    _COLLINEAR,
    _NOT_COPLANAR,
    _THROUGH_CENTRE,
    _COINCIDE,
    _ISOTROPIC,
    _SYMMETRIC,
    _I6_ZERO,
) = range(1, 9)
"""Codes of :mod:`redservo.kernels.moments`."""

__all__ = [
    "ROTATION_FEATURES",
    "ImageMoments",
    "MomentTarget",
    "RotationFeatures",
    "centred_moment_interaction",
    "centroid_interaction",
    "image_moments",
    "moment_features",
    "moment_features_interaction",
    "object_plane",
    "rotation_invariants",
]

RotationFeatures = Literal["c4c6", "pxpy", "sxsy"]
ROTATION_FEATURES: tuple[str, ...] = get_args(RotationFeatures)

_ORDER = 4
"""Centred moments are computed up to this order (L_μij of order 3 needs order 4)."""
_PLANE_TOL = 1e-8
_ISOTROPY_TOL = 1e-9
_SYMMETRY_TOL = 1e-6
_I6_TOL = 1e-9
# The seven moments the invariants depend on, in this order.
_INV_KEYS = ((2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3))


class ImageMoments(NamedTuple):
    """Moments of a set of image points (normalized coordinates)."""

    n: int
    """Number of points N (= m00)."""
    xg: float
    """Centroid abscissa ``m10/N``."""
    yg: float
    """Centroid ordinate ``m01/N``."""
    mu: FloatArray
    """(5, 5) centred moments ``mu[i, j] = μ_ij`` for ``i + j <= 4`` (zero elsewhere)."""


class MomentTarget(NamedTuple):
    """Normalization constants of ``an`` from the desired pose."""

    area: float
    """``a* = μ20* + μ02*`` (normalized units²)."""
    depth: float
    """``Z*`` (m), depth of the object plane on the ray through the desired centroid."""


# --------------------------------------------------------------------------- geometry


def object_plane(points_c: ArrayLike) -> FloatArray:
    """Return ``(A, B, C)`` (3,) with ``1/Z = A x + B y + C`` on the plane of ``points_c``.

    The plane ``n · X = d`` is fitted by SVD to the (N, 3) camera-frame points
    (m); then ``(A, B, C) = n/d`` (1/m).

    Raises:
        GeometryError: fewer than 3 points, collinear or non-coplanar points, or
            a plane through the optical centre.
        ShapeError: wrong shape or non-finite values.
    """
    P = as_matrix(points_c, "points_c", None, 3)
    return _fit_plane(P, "points_c")


def _fit_plane(P: FloatArray, name: str, *, through_centre_ok: bool = False) -> FloatArray:
    """``(A, B, C)`` of the plane of points (N, 3), validating the set (kernel ``fit_plane``).

    ``through_centre_ok`` only checks that the points span a plane (object-frame points
    may lie on a plane through the origin)."""
    if P.shape[0] < 3:
        raise GeometryError(f"{name} needs at least 3 coplanar points, got {P.shape[0]}")
    plane, code, value = _K.fit_plane(np.ascontiguousarray(P))
    if code != 0 and not (through_centre_ok and code == _THROUGH_CENTRE):
        raise _plane_error(int(code), float(value), name)
    return np.asarray(plane)


def _plane_error(code: int, value: float, name: str) -> GeometryError:
    if code == _COLLINEAR:
        return GeometryError(
            f"the points of {name} are coincident or collinear; they span no plane"
        )
    if code == _NOT_COPLANAR:
        return GeometryError(
            f"the points of {name} are not coplanar (out-of-plane spread {value:.3g} "
            f"relative to in-plane; allowed <= {_PLANE_TOL:g})"
        )
    return GeometryError(
        f"the object plane passes through the optical centre (distance {value:.3g} m); "
        "its image is a line and the moments are degenerate"
    )


def image_moments(xy: ArrayLike) -> ImageMoments:
    """Centroid and centred moments up to order 4 of image points ``xy`` (N, 2)."""
    pts = as_matrix(xy, "xy", None, 2)
    xg, yg, mu = _K.image_moments(np.ascontiguousarray(pts))
    return ImageMoments(pts.shape[0], float(xg), float(yg), mu)


# --------------------------------------------------------------------------- interaction of moments


def centroid_interaction(mom: ImageMoments, plane: ArrayLike) -> FloatArray:
    """Rows ``[L_xg; L_yg]`` (2, 6) of the centroid of points (docs/formulas.md §3.4).

    With ``1/Zg = A xg + B yg + C`` and ``n_ij = μ_ij/N``::

        L_xg = [-1/Zg, 0, xg/Zg + A n20 + B n11, xg yg + n11, -(1 + xg² + n20), yg]
        L_yg = [0, -1/Zg, yg/Zg + A n11 + B n02, 1 + yg² + n02, -(xg yg + n11), -xg]
    """
    P = np.ascontiguousarray(plane, dtype=np.float64)
    return np.asarray(_KL.centroid_rows(int(mom.n), mom.xg, mom.yg, _mu(mom), P))


def _mu(mom: ImageMoments) -> FloatArray:
    return np.ascontiguousarray(mom.mu, dtype=np.float64)


def centred_moment_interaction(
    i: int,
    j: int,
    mom: ImageMoments,
    plane: ArrayLike,
    *,
    delta: int = 0,
    eps: float = 1.0,
) -> FloatArray:
    """Interaction row ``L_μij`` (6,) of a centred moment (docs/formulas.md §3.4).

    One formula for points (``delta = 0, eps = 1``, the default) and regions
    (Chaumette 2004: ``delta = 1, eps = 4``); ``n_ij = μ_ij / μ00``, terms with
    negative indices are zero::

        μ_vx = -(i+δ) A μij - i B μ(i-1,j+1)
        μ_vy = -j A μ(i+1,j-1) - (j+δ) B μij
        μ_wx = (i+j+3δ) μ(i,j+1) + (i+2j+3δ) yg μij + i xg μ(i-1,j+1) - i ε n11 μ(i-1,j) - j ε n02 μ(i,j-1)
        μ_wy = -(i+j+3δ) μ(i+1,j) - (2i+j+3δ) xg μij - j yg μ(i+1,j-1) + i ε n20 μ(i-1,j) + j ε n11 μ(i,j-1)
        μ_vz = -A μ_wy + B μ_wx + (i+j+2δ) C μij
        μ_wz = i μ(i-1,j+1) - j μ(i+1,j-1)

    Args:
        i: First index, ``i + j <= 3`` (order 4 moments are needed).
        j: Second index.
        mom: Image moments (up to order 4).
        plane: (3,) ``(A, B, C)`` (1/m).
        delta: 0 for points, 1 for regions.
        eps: 1 for points, 4 for regions.
    """
    if i < 0 or j < 0 or i + j > _ORDER - 1:
        raise ConfigurationError(f"L_mu is available for 0 <= i + j <= 3, got (i, j) = ({i}, {j})")
    P = np.ascontiguousarray(plane, dtype=np.float64)
    row = _KL.centred_moment_row(
        int(i), int(j), _mu(mom), float(mom.xg), float(mom.yg), P, int(delta), float(eps)
    )
    return np.asarray(row)


# --------------------------------------------------------------------------- features


def rotation_invariants(mu: ArrayLike, kind: RotationFeatures = "c4c6") -> NDArray[Any]:
    """The two rotation features (2,) from ``mu = (μ20, μ11, μ02, μ30, μ21, μ12, μ03)``.

    Pure arithmetic, so it also accepts complex input (used for complex-step
    differentiation). Definitions (docs/formulas.md §3.4)::

        I6 = 3 μ12⁴ + 2 μ30 μ12³ + (3 μ30² - 6 μ03 μ21) μ12² - 6 μ30 μ21 (μ21 + μ03) μ12
             + 2 μ30² μ03² + 2 μ21³ μ03 + 3 μ21² μ03² + 3 μ21⁴
        I7 = (3 μ21 + 2 μ03) μ12³ + 3 μ30 (μ03 + 2 μ21) μ12²
             - 3 μ21 (μ30 + μ03 + μ21)(-μ30 + μ03 + μ21) μ12
             + μ30 (-μ30² μ03 - 2 μ21³ - 3 μ03 μ21² + μ03³)
        I9 = (μ03² + 3 μ03 μ21 + μ30 (μ30 + 3 μ12))²
        c4c6: (I7/I6, I9/I6)
        pxpy: (I1/I3², I2/I3³)
        sxsy: ((c2 c3 + s2 s3)/K, (s2 c3 - c2 s3)/K),  K = I1 I3^(3/2)/sqrt(a),  a = I3
    """
    if kind not in _KIND:
        raise ConfigurationError(
            f"unknown rotation features {kind!r}; allowed: {', '.join(ROTATION_FEATURES)}"
        )
    arr = np.asarray(mu)
    if np.iscomplexobj(arr):
        return np.asarray(_K.rotation_invariants(np.ascontiguousarray(arr, complex), _KIND[kind]))
    return np.asarray(_K.rotation_invariants(np.ascontiguousarray(arr, float), _KIND[kind]))


def _check_moments(mom: ImageMoments, kind: RotationFeatures) -> None:
    """Raise GeometryError where the features are undefined or singular."""
    code, _ = _K.check_moments(_mu(mom), _KIND[kind])
    if code != 0:
        raise _moment_error(int(code), kind)


def _moment_error(code: int, kind: str) -> GeometryError:
    if code == _COINCIDE:
        return GeometryError("the image points coincide; the moment features are undefined")
    if code == _ISOTROPIC:
        return GeometryError(
            "the second-order moments are isotropic (μ20 = μ02, μ11 = 0), so the orientation α "
            "is undefined; use a point set without 3-fold or 4-fold symmetry"
        )
    if code == _SYMMETRIC:
        return GeometryError(
            "the third-order moments vanish (a centrally symmetric point set, e.g. a square "
            f"or a rectangle), so the rotation features {kind!r} are undefined or singular; "
            "use a non-symmetric point set"
        )
    return GeometryError(
        "the invariant I6 vanishes (e.g. collinear image points), so C4 = I7/I6 and "
        "C6 = I9/I6 are undefined; use another pose or rotation_features='pxpy'"
    )


def moment_features(
    mom: ImageMoments,
    *,
    area_star: float,
    depth_star: float,
    rotation_features: RotationFeatures = "c4c6",
) -> FloatArray:
    """The six features ``(xn, yn, an, α, r1, r2)`` (6,) (module docstring).

    Raises:
        GeometryError: the moments are degenerate for these features.
    """
    _check_moments(mom, rotation_features)
    s = _K.moment_features(
        float(mom.xg),
        float(mom.yg),
        _mu(mom),
        float(area_star),
        float(depth_star),
        _KIND[rotation_features],
    )
    return np.asarray(s)


def moment_features_interaction(
    mom: ImageMoments,
    plane: ArrayLike,
    *,
    area_star: float,
    depth_star: float,
    rotation_features: RotationFeatures = "c4c6",
) -> FloatArray:
    """Interaction matrix (6, 6) of ``(xn, yn, an, α, r1, r2)`` for a general plane.

    Chain rule (``a = μ20 + μ02``, ``Δ = (μ20 - μ02)² + 4 μ11²``)::

        L_an = -an/(2a) (L_μ20 + L_μ02)
        L_xn = an L_xg + xg L_an,   L_yn = an L_yg + yg L_an
        L_α  = ((μ20 - μ02) L_μ11 - μ11 (L_μ20 - L_μ02)) / Δ
        L_r  = Σ ∂r/∂μ_ij L_μij      (∂r/∂μ by complex step)

    Args:
        mom: Image moments up to order 4.
        plane: (3,) ``(A, B, C)`` of the object plane (1/m).
        area_star: ``a*``.
        depth_star: ``Z*`` (m).
        rotation_features: See the module docstring.
    """
    L = _KL.moment_features_interaction(
        int(mom.n),
        float(mom.xg),
        float(mom.yg),
        _mu(mom),
        np.ascontiguousarray(plane, dtype=np.float64),
        float(area_star),
        float(depth_star),
        _KIND[rotation_features],
    )
    return np.asarray(L)
