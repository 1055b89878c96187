"""The image of a 3-D point, ``s = (x, y)`` (docs/formulas.md §3.1; CM01 eq. 26)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_transform, as_vector
from redservo.camera import MIN_DEPTH
from redservo.errors import GeometryError
from redservo.features.base import Feature, Measurement
from redservo.features.kinds import FeatureKind
from redservo.kernels import lazy

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import features as _K
else:
    _K = lazy("features")

__all__ = ["PointFeature", "point_interaction", "project_point"]


def project_point(point_c: ArrayLike) -> tuple[float, float, float]:
    """Return ``(x, y, 1/Z)`` of a point ``(X, Y, Z)`` (3,) given in the camera frame (m).

    Raises:
        GeometryError: ``Z <= MIN_DEPTH`` (the point is at or behind the camera plane).
    """
    X, Y, Z = as_vector(point_c, "point_c", 3)
    x, y, inv_z, ok = _K.project_point(float(X), float(Y), float(Z))
    if not ok:
        raise _behind(float(Z))
    return float(x), float(y), float(inv_z)


def _behind(Z: float) -> GeometryError:
    return GeometryError(
        f"the point is at or behind the camera plane (Z = {Z:.6g} m); "
        f"a point feature needs Z > {MIN_DEPTH:g} m"
    )


def point_interaction(x: float, y: float, inv_z: float) -> FloatArray:
    """Interaction matrix (2, 6) of a normalized image point (CM01 eq. 26, docs/formulas.md §3.1).

    ``L = [[-1/Z, 0, x/Z, x y, -(1 + x²), y], [0, -1/Z, y/Z, 1 + y², -x y, -x]]``
    (CM01 prints its transpose ``L_P^T``).

    Args:
        x: Normalized abscissa ``X/Z``.
        y: Normalized ordinate ``Y/Z``.
        inv_z: Inverse depth ``1/Z`` (1/m).
    """
    return np.asarray(_K.point_interaction(float(x), float(y), float(inv_z)))


class PointFeature(Feature):
    """The normalized image ``s = (x, y)`` of a point fixed in the object frame.

    ``inv_depth = (1/Z,)``. CM01's gazing task uses it with the object's centre
    of gravity and ``s* = (0, 0)``.

    Args:
        point_o: (3,) the point in the object frame (m), default the origin.
    """

    names = ("x", "y")
    angular = (False, False)

    def __init__(self, point_o: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        self.point_o = as_vector(point_o, "point_o", 3)
        self._points = np.ascontiguousarray(self.point_o.reshape(1, 3))

    def measure(self, cMo: FloatArray) -> Measurement:
        return self._measure_trusted(np.ascontiguousarray(as_transform(cMo, "cMo")))

    def _measure_trusted(self, cMo: FloatArray) -> Measurement:
        T = np.ascontiguousarray(cMo)
        s, inv_z, bad = _K.points_measure(T, self._points)
        if bad >= 0:
            raise _behind(float(T[2, :3] @ self.point_o + T[2, 3]))
        return Measurement(s, inv_z)

    def interaction(self, s: FloatArray, inv_depth: FloatArray) -> FloatArray:
        x, y = as_vector(s, "s", 2)
        (inv_z,) = as_vector(inv_depth, "inv_depth", 1)
        return point_interaction(float(x), float(y), float(inv_z))

    def __repr__(self) -> str:
        return f"PointFeature(point_o={self.point_o.tolist()})"


KIND = FeatureKind(
    "point",
    PointFeature,
    schema="redservo.schema.features:PointSpec",
    obj="redservo.scene:PointSet",
    render="redservo.vision.shapes:_point_layers",
    mujoco="redservo.physics.scenes:points_geoms",
    viewer="redservo.viewer.playback:points_primitive",
    image_term="redservo.vision.measure:point_term",
    measure_image="redservo.vision.measure:measure_dot_point",
    depth="redservo.vision.depth:point_depth",
    draw="redservo.vision.overlay:draw_point_term",
)
"""The point kind and the adapters of the point sets it observes (:mod:`redservo.features.kinds`)."""
