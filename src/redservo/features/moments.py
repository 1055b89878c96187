"""Decoupled moment features of a set of coplanar points (Tahri & Chaumette 2005; docs/formulas.md §3.4).

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
chain rule from the centroid rows and from ``L_μij`` (docs/formulas.md §3.4, with
``δ = 0``, ``ε = 1`` for points). The derivatives of ``r1, r2`` with respect to
the moments use complex-step differentiation, exact to rounding for these
rational functions.

**Rotation features** (decision; the papers do not give the exact pair, docs/formulas.md §3.4).
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
  moments vanish) and for collinear images (checked here; docs/formulas.md §3.4).
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
from typing import Any, Literal, NamedTuple, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray, as_matrix, as_transform, as_vector
from redservo.camera import MIN_DEPTH, project_points
from redservo.errors import ConfigurationError, GeometryError
from redservo.features.base import Feature, Measurement, wrap_angle
from redservo.kernels import lazy

_K = lazy("moments")
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
    return np.asarray(_K.centroid_rows(int(mom.n), mom.xg, mom.yg, _mu(mom), P))


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
    row = _K.centred_moment_row(
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
    L = _K.moment_features_interaction(
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
        _fit_plane(P, "points_o", through_centre_ok=True)
        if rotation_features not in ROTATION_FEATURES:
            raise ConfigurationError(
                f"unknown rotation features {rotation_features!r}; "
                f"allowed: {', '.join(ROTATION_FEATURES)}"
            )
        for name, value in (("desired_area", desired_area), ("desired_depth", desired_depth)):
            if not (np.isfinite(value) and value > 0.0):
                raise ConfigurationError(f"{name} must be positive and finite, got {value!r}")
        self.points_o = P
        self._points = np.ascontiguousarray(P)
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
        T = np.ascontiguousarray(as_transform(cMo, "cMo"))
        s, plane, xg, yg, mu, code, value = _K.moment_measure(
            self._points,
            T,
            self.desired_area,
            self.desired_depth,
            _KIND[self.rotation_features],
        )
        if code != 0:
            raise self._measure_error(int(code), float(value), s)
        mom = ImageMoments(self._points.shape[0], float(xg), float(yg), mu)
        key = s.tobytes()
        self._cache[key] = (s, mom)
        self._cache.move_to_end(key)
        while len(self._cache) > _CACHE_SIZE:
            self._cache.popitem(last=False)
        return Measurement(s, plane)

    def _measure_error(self, code: int, value: float, s: FloatArray) -> GeometryError:
        if code == _BEHIND:
            return GeometryError(
                f"point {int(value)} is at or behind the camera plane (Z = {float(s[0]):.6g} m); "
                f"projection needs Z > {MIN_DEPTH:g} m"
            )
        if code in (_COLLINEAR, _NOT_COPLANAR, _THROUGH_CENTRE):
            return _plane_error(code, value, "points_c")
        return _moment_error(code, self.rotation_features)

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
