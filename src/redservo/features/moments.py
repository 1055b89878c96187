"""Decoupled moment features of a set of coplanar points (Tahri & Chaumette 2005; literature.md A4).

For N coplanar points with normalized images ``(x_k, y_k)``: ``m_ij = Σ x^i y^j``,
``xg = m10/N``, ``yg = m01/N``, centred moments ``μ_ij = Σ (x - xg)^i (y - yg)^j``
(not divided by N) and ``n_ij = μ_ij / N``. The object plane is
``1/Z = A x + B y + C``; ``inv_depth = (A, B, C)``.

The six features, ``s = (xn, yn, an, α, r1, r2)``::

    a  = μ20 + μ02           (N is constant for points, so a replaces the area)
    an = Z* sqrt(a*/a),  xn = an xg,  yn = an yg
    α  = ½ atan2(2 μ11, μ20 - μ02)            (rad, in (-π/2, π/2])
    r1, r2: two similarity invariants built on third-order moments, for ω_x, ω_y

``a*`` and ``Z*`` are the value of ``a`` and the depth at the desired pose; with
them ``an = Z`` exactly at any pose where the object plane is parallel to the
image plane, and the translational block of ``(xn, yn, an)`` is ``-I3`` there.

Interaction matrices hold for a general object plane: every feature is a
function of ``(xg, yg)`` and of the centred moments, so ``L_s`` follows by the
chain rule from the centroid rows and from ``L_μij`` (literature.md A4, with
``δ = 0``, ``ε = 1`` for points). The derivatives of ``r1, r2`` with respect to
the moments use complex-step differentiation, exact to rounding for these
rational functions.

**Rotation features** (decision; literature.md A4 is [?] on Tahri's exact pair).
``rotation_features`` selects:

* ``"c4c6"`` (default): ``C4 = I7/I6``, ``C6 = I9/I6``, the third-order invariants
  of ViSP's discrete-points example. For points they are invariant to 2-D
  translation, rotation and scale, so at a parallel pose their ``v`` columns
  and their ``ω_z`` column vanish exactly: they react to ``ω_x, ω_y`` only and
  do not couple with ``α`` or with ``an``. This is the decoupling MC05 §V
  describes ("third order moments to decouple v_x, v_y from ω_y, ω_x").
  Singular set: ``I6 = |c30|⁴ + 9|c21|⁴ + 6|c30|²|c21|² - 16 Re(c30 c̄21³)``
  (× 1/64, with ``c_pq = Σ (z - zg)^p (z̄ - z̄g)^q``) is ≥ 0 by AM-GM and vanishes
  iff ``c30 = c21³/|c21|²``: for every centrally symmetric set (all third-order
  moments vanish) and for collinear images (checked here, not in literature.md).
* ``"pxpy"``: ``Px = I1/I3²`` and ``Py = I2/I3³`` (not ViSP's ``a I2/I3³``,
  which scales as s² for points). Also similarity invariants, defined
  everywhere, but ``Py``'s gradient vanishes for symmetric sets.
* ``"sxsy"``: ViSP's region features ``Sx, Sy`` with ``K = I1 I3^(3/2)/sqrt(a)``
  and ``a = μ20 + μ02``. For points they are neither rotation invariant (their
  ``ω_z`` column is ``(-Sy, Sx)``, coupling with ``α``) nor scale invariant
  (they scale as s¹); kept for comparison with region-based set-ups.

Here ``c1 = μ20 - μ02``, ``s1 = 2 μ11``, ``c2 = μ03 - 3 μ21``, ``s2 = μ30 - 3 μ12``,
``c3 = c1² - s1²``, ``s3 = 2 s1 c1``, ``I1 = c1² + s1²``, ``I2 = c2² + s2²``,
``I3 = μ20 + μ02``; I6, I7, I9 are given in :func:`rotation_invariants`.

Other decisions:
    * ``Z*`` is the depth of the object plane along the ray through the image
      centroid at the desired pose, ``1/(A* xg* + B* yg* + C*)``; it equals the
      plane's depth when the desired pose is parallel.
    * ``α`` has period π (an orientation), so :meth:`MomentFeatures.error`
      wraps its error to (-π/2, π/2], not (-π, π]: with rotation-invariant
      ``r1, r2`` nothing tells ``α`` from ``α + π``.
    * ``L_s`` needs moments up to order 4, which ``s`` does not contain. A
      :class:`MomentFeatures` remembers the image moments of its recent
      measurements and :meth:`MomentFeatures.interaction` uses those whose
      ``s`` is nearest to the given one (exactly equal in normal use; the true
      measurement when the caller added noise to ``s``). It raises
      :class:`ConfigurationError` when no measurement lies within 0.1 of ``s``
      in every component. :func:`moment_features_interaction` is the pure form.
    * Degenerate input raises :class:`GeometryError`: fewer than 3 points,
      collinear or non-coplanar points (relative tolerance 1e-8 on the singular
      values), a point at or behind the camera, an object plane through the
      optical centre, isotropic second-order moments (``α`` undefined; relative
      tolerance 1e-9), and for ``"c4c6"``/``"pxpy"`` vanishing third-order moments
      (centrally symmetric set; ``|μ3| / I3^(3/2) < 1e-6``) or, for ``"c4c6"``,
      ``I6 / |μ3|⁴ < 1e-9``.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable
from typing import Any, Literal, NamedTuple, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray, as_matrix, as_transform, as_vector
from redservo.camera import project_points
from redservo.errors import ConfigurationError, GeometryError
from redservo.features.base import Feature, Measurement, wrap_angle

__all__ = [
    "ROTATION_FEATURES",
    "ImageMoments",
    "MomentFeatures",
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

_ROTATION_NAMES: dict[str, tuple[str, str]] = {
    "c4c6": ("c4", "c6"),
    "pxpy": ("px", "py"),
    "sxsy": ("sx", "sy"),
}
_ORDER = 4
"""Centred moments are computed up to this order (L_μij of order 3 needs order 4)."""
_PLANE_TOL = 1e-8
_ISOTROPY_TOL = 1e-9
_SYMMETRY_TOL = 1e-6
_I6_TOL = 1e-9
_MATCH_TOL = 0.1
_CACHE_SIZE = 32
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
    normal, centroid = _fit_plane(P, "points_c")
    d = float(normal @ centroid)
    if abs(d) <= 1e-6:
        raise GeometryError(
            f"the object plane passes through the optical centre (distance {abs(d):.3g} m); "
            "its image is a line and the moments are degenerate"
        )
    return np.asarray(normal / d, dtype=float)


def _fit_plane(P: FloatArray, name: str) -> tuple[FloatArray, FloatArray]:
    """Unit normal and centroid of coplanar points (N, 3), validating the set."""
    if P.shape[0] < 3:
        raise GeometryError(f"{name} needs at least 3 coplanar points, got {P.shape[0]}")
    centroid = P.mean(axis=0)
    _, sv, Vt = np.linalg.svd(P - centroid)
    if sv[0] <= 0.0 or sv[1] <= _PLANE_TOL * sv[0]:
        raise GeometryError(f"the points of {name} are coincident or collinear; they span no plane")
    if sv[2] > _PLANE_TOL * sv[0]:
        raise GeometryError(
            f"the points of {name} are not coplanar (out-of-plane spread {sv[2] / sv[0]:.3g} "
            f"relative to in-plane; allowed <= {_PLANE_TOL:g})"
        )
    return np.asarray(Vt[2], dtype=float), np.asarray(centroid, dtype=float)


def image_moments(xy: ArrayLike) -> ImageMoments:
    """Centroid and centred moments up to order 4 of image points ``xy`` (N, 2)."""
    pts = as_matrix(xy, "xy", None, 2)
    n = pts.shape[0]
    xg, yg = pts.mean(axis=0)
    dx, dy = pts[:, 0] - xg, pts[:, 1] - yg
    px = np.vander(dx, _ORDER + 1, increasing=True)  # (N, 5): dx^i
    py = np.vander(dy, _ORDER + 1, increasing=True)
    mu = px.T @ py  # mu[i, j] = Σ dx^i dy^j
    i, j = np.indices(mu.shape)
    mu[i + j > _ORDER] = 0.0
    return ImageMoments(n, float(xg), float(yg), mu)


# --------------------------------------------------------------------------- interaction of moments


def centroid_interaction(mom: ImageMoments, plane: ArrayLike) -> FloatArray:
    """Rows ``[L_xg; L_yg]`` (2, 6) of the centroid of points (literature.md A4).

    With ``1/Zg = A xg + B yg + C`` and ``n_ij = μ_ij/N``::

        L_xg = [-1/Zg, 0, xg/Zg + A n20 + B n11, xg yg + n11, -(1 + xg² + n20), yg]
        L_yg = [0, -1/Zg, yg/Zg + A n11 + B n02, 1 + yg² + n02, -(xg yg + n11), -xg]
    """
    A, B, C = np.asarray(plane, dtype=float)
    xg, yg = mom.xg, mom.yg
    n20, n11, n02 = mom.mu[2, 0] / mom.n, mom.mu[1, 1] / mom.n, mom.mu[0, 2] / mom.n
    izg = A * xg + B * yg + C
    return np.array(
        [
            [-izg, 0.0, xg * izg + A * n20 + B * n11, xg * yg + n11, -(1.0 + xg * xg + n20), yg],
            [0.0, -izg, yg * izg + A * n11 + B * n02, 1.0 + yg * yg + n02, -(xg * yg + n11), -xg],
        ]
    )


def centred_moment_interaction(
    i: int,
    j: int,
    mom: ImageMoments,
    plane: ArrayLike,
    *,
    delta: int = 0,
    eps: float = 1.0,
) -> FloatArray:
    """Interaction row ``L_μij`` (6,) of a centred moment (literature.md A4).

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
    A, B, C = np.asarray(plane, dtype=float)
    mu = mom.mu
    xg, yg = mom.xg, mom.yg

    def m(p: int, q: int) -> float:
        return float(mu[p, q]) if p >= 0 and q >= 0 else 0.0

    m00 = m(0, 0)
    n20, n11, n02 = m(2, 0) / m00, m(1, 1) / m00, m(0, 2) / m00
    d = delta
    vx = -(i + d) * A * m(i, j) - i * B * m(i - 1, j + 1)
    vy = -j * A * m(i + 1, j - 1) - (j + d) * B * m(i, j)
    wx = (
        (i + j + 3 * d) * m(i, j + 1)
        + (i + 2 * j + 3 * d) * yg * m(i, j)
        + i * xg * m(i - 1, j + 1)
        - i * eps * n11 * m(i - 1, j)
        - j * eps * n02 * m(i, j - 1)
    )
    wy = (
        -(i + j + 3 * d) * m(i + 1, j)
        - (2 * i + j + 3 * d) * xg * m(i, j)
        - j * yg * m(i + 1, j - 1)
        + i * eps * n20 * m(i - 1, j)
        + j * eps * n11 * m(i, j - 1)
    )
    vz = -A * wy + B * wx + (i + j + 2 * d) * C * m(i, j)
    wz = i * m(i - 1, j + 1) - j * m(i + 1, j - 1)
    return np.array([vx, vy, vz, wx, wy, wz])


# --------------------------------------------------------------------------- features


def _i6(m30: Any, m21: Any, m12: Any, m03: Any) -> Any:
    """The invariant I6 of :func:`rotation_invariants`; real or complex input."""
    return (
        3 * m12**4
        + 2 * m30 * m12**3
        + (3 * m30**2 - 6 * m03 * m21) * m12**2
        - 6 * m30 * m21 * (m21 + m03) * m12
        + 2 * m30**2 * m03**2
        + 2 * m21**3 * m03
        + 3 * m21**2 * m03**2
        + 3 * m21**4
    )


def rotation_invariants(mu: ArrayLike, kind: RotationFeatures = "c4c6") -> NDArray[Any]:
    """The two rotation features (2,) from ``mu = (μ20, μ11, μ02, μ30, μ21, μ12, μ03)``.

    Pure arithmetic, so it also accepts complex input (used for complex-step
    differentiation). Definitions (literature.md A4)::

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
    m20, m11, m02, m30, m21, m12, m03 = np.asarray(mu)
    if kind == "c4c6":
        I6 = _i6(m30, m21, m12, m03)
        I7 = (
            (3 * m21 + 2 * m03) * m12**3
            + 3 * m30 * (m03 + 2 * m21) * m12**2
            - 3 * m21 * (m30 + m03 + m21) * (-m30 + m03 + m21) * m12
            + m30 * (-(m30**2) * m03 - 2 * m21**3 - 3 * m03 * m21**2 + m03**3)
        )
        I9 = (m03**2 + 3 * m03 * m21 + m30 * (m30 + 3 * m12)) ** 2
        return np.array([I7 / I6, I9 / I6])
    c1, s1 = m20 - m02, 2 * m11
    c2, s2 = m03 - 3 * m21, m30 - 3 * m12
    I1 = c1**2 + s1**2
    I3 = m20 + m02
    if kind == "pxpy":
        I2 = c2**2 + s2**2
        return np.array([I1 / I3**2, I2 / I3**3])
    if kind == "sxsy":
        c3, s3 = c1**2 - s1**2, 2 * s1 * c1
        K = I1 * I3**1.5 / np.sqrt(I3)
        return np.array([(c2 * c3 + s2 * s3) / K, (s2 * c3 - c2 * s3) / K])
    raise ConfigurationError(
        f"unknown rotation features {kind!r}; allowed: {', '.join(ROTATION_FEATURES)}"
    )


def _invariant_inputs(mom: ImageMoments) -> FloatArray:
    return np.array([mom.mu[k] for k in _INV_KEYS])


def _check_moments(mom: ImageMoments, kind: RotationFeatures) -> None:
    """Raise GeometryError where the features are undefined or singular."""
    mu = mom.mu
    I3 = float(mu[2, 0] + mu[0, 2])
    if not I3 > 0.0:
        raise GeometryError("the image points coincide; the moment features are undefined")
    delta = float(np.hypot(mu[2, 0] - mu[0, 2], 2.0 * mu[1, 1]))
    if delta <= _ISOTROPY_TOL * I3:
        raise GeometryError(
            "the second-order moments are isotropic (μ20 = μ02, μ11 = 0), so the orientation α "
            "is undefined; use a point set without 3-fold or 4-fold symmetry"
        )
    if kind in ("c4c6", "pxpy"):
        third = np.array([mu[3, 0], mu[2, 1], mu[1, 2], mu[0, 3]])
        t3 = float(np.sqrt(third @ third))
        if t3 <= _SYMMETRY_TOL * I3**1.5:
            raise GeometryError(
                "the third-order moments vanish (a centrally symmetric point set, e.g. a square "
                f"or a rectangle), so the rotation features {kind!r} are undefined or singular; "
                "use a non-symmetric point set"
            )
        if kind == "c4c6":
            I6 = float(_i6(mu[3, 0], mu[2, 1], mu[1, 2], mu[0, 3]))
            if I6 <= _I6_TOL * t3**4:
                raise GeometryError(
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
    mu = mom.mu
    a = mu[2, 0] + mu[0, 2]
    an = depth_star * np.sqrt(area_star / a)
    alpha = 0.5 * np.arctan2(2.0 * mu[1, 1], mu[2, 0] - mu[0, 2])
    r = rotation_invariants(_invariant_inputs(mom), rotation_features).real
    return np.array([an * mom.xg, an * mom.yg, an, alpha, r[0], r[1]], dtype=float)


def _complex_step_jacobian(
    f: Callable[[NDArray[Any]], NDArray[Any]], x: FloatArray, h: float = 1e-30
) -> FloatArray:
    """Jacobian (m, n) of ``f`` at real ``x`` (n,) by complex steps: ``Im f(x + i h e_k) / h``."""
    cols = []
    for k in range(x.shape[0]):
        xc = x.astype(complex)
        xc[k] += 1j * h
        cols.append(np.imag(f(xc)) / h)
    return np.asarray(np.stack(cols, axis=1), dtype=float)


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
    P = np.asarray(plane, dtype=float)
    mu = mom.mu
    Lmu = {k: centred_moment_interaction(k[0], k[1], mom, P) for k in _INV_KEYS}
    a = mu[2, 0] + mu[0, 2]
    an = depth_star * np.sqrt(area_star / a)
    L_g = centroid_interaction(mom, P)
    L_an = -an / (2.0 * a) * (Lmu[2, 0] + Lmu[0, 2])
    c1 = mu[2, 0] - mu[0, 2]
    Delta = c1 * c1 + 4.0 * mu[1, 1] ** 2
    L_alpha = (c1 * Lmu[1, 1] - mu[1, 1] * (Lmu[2, 0] - Lmu[0, 2])) / Delta
    grad = _complex_step_jacobian(
        lambda x: rotation_invariants(x, rotation_features), _invariant_inputs(mom)
    )
    L_r = grad @ np.stack([Lmu[k] for k in _INV_KEYS])
    return np.vstack(
        [
            an * L_g[0] + mom.xg * L_an,
            an * L_g[1] + mom.yg * L_an,
            L_an,
            L_alpha,
            L_r,
        ]
    )


# --------------------------------------------------------------------------- the Feature


class MomentFeatures(Feature):
    """The six decoupled moment features of coplanar points fixed in the object frame.

    ``s = (xn, yn, an, α, r1, r2)``, ``inv_depth = (A, B, C)`` of the object
    plane. See the module docstring for the definitions and decisions.

    Args:
        points_o: (N, 3) coplanar points in the object frame (m), N >= 3.
        desired_area: ``a*`` (> 0), from :meth:`desired_from`.
        desired_depth: ``Z*`` (m, > 0), from :meth:`desired_from`.
        rotation_features: ``"c4c6"`` (default), ``"pxpy"`` or ``"sxsy"``.
    """

    def __init__(
        self,
        points_o: ArrayLike,
        *,
        desired_area: float,
        desired_depth: float,
        rotation_features: RotationFeatures = "c4c6",
    ) -> None:
        P = as_matrix(points_o, "points_o", None, 3)
        _fit_plane(P, "points_o")
        if rotation_features not in ROTATION_FEATURES:
            raise ConfigurationError(
                f"unknown rotation features {rotation_features!r}; "
                f"allowed: {', '.join(ROTATION_FEATURES)}"
            )
        for name, value in (("desired_area", desired_area), ("desired_depth", desired_depth)):
            if not (np.isfinite(value) and value > 0.0):
                raise ConfigurationError(f"{name} must be positive and finite, got {value!r}")
        self.points_o = P
        self.desired_area = float(desired_area)
        self.desired_depth = float(desired_depth)
        self.rotation_features: RotationFeatures = rotation_features
        self.names = ("xn", "yn", "an", "alpha", *_ROTATION_NAMES[rotation_features])
        self.angular = (False, False, False, True, False, False)
        self._cache: OrderedDict[bytes, tuple[FloatArray, ImageMoments]] = OrderedDict()

    @staticmethod
    def desired_from(points_c: ArrayLike) -> MomentTarget:
        """Return ``(a*, Z*)`` from the points (N, 3) in the desired camera frame (m).

        Raises:
            GeometryError: invalid point set or a point behind the camera.
        """
        P = as_matrix(points_c, "points_c", None, 3)
        plane = object_plane(P)
        mom = image_moments(project_points(P))
        izg = float(plane @ [mom.xg, mom.yg, 1.0])
        if izg <= 0.0:
            raise GeometryError("the object plane is behind the camera along the centroid ray")
        return MomentTarget(float(mom.mu[2, 0] + mom.mu[0, 2]), 1.0 / izg)

    @classmethod
    def at_desired_pose(
        cls,
        points_o: ArrayLike,
        cMo_star: ArrayLike,
        *,
        rotation_features: RotationFeatures = "c4c6",
    ) -> MomentFeatures:
        """Build the features normalized at the desired object pose ``cMo_star`` (4x4)."""
        P = as_matrix(points_o, "points_o", None, 3)
        T = as_transform(cMo_star, "cMo_star")
        target = cls.desired_from(P @ T[:3, :3].T + T[:3, 3])
        feat = cls(
            P,
            desired_area=target.area,
            desired_depth=target.depth,
            rotation_features=rotation_features,
        )
        feat.measure(T)  # validates the desired pose and caches its moments
        return feat

    def measure(self, cMo: FloatArray) -> Measurement:
        T = as_transform(cMo, "cMo")
        P = self.points_o @ T[:3, :3].T + T[:3, 3]
        mom = image_moments(project_points(P))
        plane = object_plane(P)
        s = moment_features(
            mom,
            area_star=self.desired_area,
            depth_star=self.desired_depth,
            rotation_features=self.rotation_features,
        )
        key = s.tobytes()
        self._cache[key] = (s, mom)
        self._cache.move_to_end(key)
        while len(self._cache) > _CACHE_SIZE:
            self._cache.popitem(last=False)
        return Measurement(s, plane)

    def _moments_for(self, s: FloatArray) -> ImageMoments:
        hit = self._cache.get(s.tobytes())
        if hit is not None:
            return hit[1]
        best, best_dist = None, np.inf
        for s_c, mom in self._cache.values():
            dist = float(np.max(np.abs(self.error(s, s_c))))
            if dist < best_dist:
                best, best_dist = mom, dist
        if best is None or best_dist > _MATCH_TOL:
            raise ConfigurationError(
                "MomentFeatures.interaction needs the image moments of s, which s does not "
                "contain: call measure() at this pose first (no measured value lies within "
                f"{_MATCH_TOL} of s = {np.array2string(s, precision=4)})"
            )
        return best

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        sv = as_vector(s, "s", 6)
        plane = as_vector(inv_depth, "inv_depth", 3)
        return moment_features_interaction(
            self._moments_for(sv),
            plane,
            area_star=self.desired_area,
            depth_star=self.desired_depth,
            rotation_features=self.rotation_features,
        )

    def error(self, s: FloatArray, s_star: FloatArray) -> FloatArray:
        """Return ``s - s*`` (6,) with the α error wrapped to (-π/2, π/2] (α has period π)."""
        e = np.asarray(s, dtype=float) - np.asarray(s_star, dtype=float)
        e = e.copy()
        e[3] = 0.5 * wrap_angle(2.0 * e[3])
        return e

    def __repr__(self) -> str:
        return (
            f"MomentFeatures({self.points_o.shape[0]} points, desired_area={self.desired_area:.6g}, "
            f"desired_depth={self.desired_depth:.6g}, rotation_features={self.rotation_features!r})"
        )
