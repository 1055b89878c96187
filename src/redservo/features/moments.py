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

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_matrix, as_transform, as_vector
from redservo.camera import MIN_DEPTH, project_points
from redservo.errors import ConfigurationError, GeometryError
from redservo.features.base import Feature, Measurement, wrap_angle
from redservo.features.kinds import FeatureKind
from redservo.features.moment_math import (
    _BEHIND,
    _COLLINEAR,
    _K,
    _KIND,
    _NOT_COPLANAR,
    _THROUGH_CENTRE,
    ROTATION_FEATURES,
    ImageMoments,
    MomentTarget,
    RotationFeatures,
    _fit_plane,
    _moment_error,
    _plane_error,
    centred_moment_interaction,
    centroid_interaction,
    image_moments,
    moment_features,
    moment_features_interaction,
    object_plane,
    rotation_invariants,
)

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

_ROTATION_NAMES: dict[str, tuple[str, str]] = {
    "c4c6": ("c4", "c6"),
    "pxpy": ("px", "py"),
    "sxsy": ("sx", "sy"),
}
_MATCH_TOL = 0.1
_CACHE_SIZE = 32


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
        return self._measure_trusted(as_transform(cMo, "cMo"))

    def _measure_trusted(self, cMo: FloatArray) -> Measurement:
        T = np.ascontiguousarray(cMo)
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

    def predicted(self, s: FloatArray, measured: FloatArray) -> None:
        """Let :meth:`interaction` at ``s`` (6,), a prediction from the measured value
        ``measured`` (6,) (a camera's latency compensated, :mod:`redservo.control.latency`),
        use the image moments of ``measured``: the interaction matrix stays linearised at
        the last image, as the first-order prediction itself is."""
        mom = self._moments_for(as_vector(measured, "measured", 6))
        sv = np.array(as_vector(s, "s", 6), dtype=float)
        self._cache[sv.tobytes()] = (sv, mom)
        while len(self._cache) > _CACHE_SIZE:
            self._cache.popitem(last=False)

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


KIND = FeatureKind(
    "moments",
    MomentFeatures,
    schema="redservo.schema.features:MomentsSpec",
    obj="redservo.scene:PointSet",
    image_term="redservo.vision.measure:moments_term",
    measure_image="redservo.vision.measure:measure_dot_moments",
    depth="redservo.vision.depth:moments_depth",
    draw="redservo.vision.overlay:draw_moments",
)
"""The moments kind; it observes point sets, drawn by the point kind (:mod:`redservo.features.kinds`)."""
