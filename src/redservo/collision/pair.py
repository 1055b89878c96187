"""One pair's distance: its record, coal's signed query and the normal between the witness
points; shared by the capsule queries (:mod:`redservo.collision.query`) and the URDF
elements' (:mod:`redservo.collision.urdf_query`). Units: m, world frame."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from redservo._validation import FloatArray

__all__ = ["DistanceRecord", "PairKind"]

PairKind = Literal["environment", "self"]

_TOLERANCE = 1e-10
"""GJK/EPA tolerance (m): coal's default, 1e-6, would make the distance of curved pairs
(cylinders, boxes against capsules) a staircase at that scale and its derivative noise."""


@dataclass(frozen=True)
class DistanceRecord:
    """One pair's distance (module docstring; m, base = world frame)."""

    first: str
    """The robot link (a :class:`~redservo.collision.robot.LinkCapsule` name)."""
    second: str
    """The obstacle's name, or the other link's."""
    kind: PairKind
    distance: float
    a: FloatArray
    b: FloatArray
    normal: FloatArray
    jacobian: FloatArray


def _transform(M: FloatArray) -> Any:
    import coal

    return coal.Transform3s(np.ascontiguousarray(M[:3, :3]), np.ascontiguousarray(M[:3, 3]))


def _query(g1: Any, tf1: Any, g2: Any, tf2: Any) -> tuple[float, FloatArray, FloatArray]:
    import coal

    req = coal.DistanceRequest()
    req.enable_signed_distance = True
    req.gjk_tolerance = req.epa_tolerance = _TOLERANCE
    res = coal.DistanceResult()
    coal.distance(g1, tf1, g2, tf2, req, res)
    return float(res.min_distance), res.getNearestPoint1().copy(), res.getNearestPoint2().copy()


def _normal(d: float, a: FloatArray, b: FloatArray, fallback: FloatArray) -> FloatArray:
    """Unit vector from ``b`` towards ``a`` (away from ``b`` when they overlap)."""
    v = a - b
    norm = float(np.linalg.norm(v))
    if norm < 1e-12:
        return fallback
    return np.asarray(v / norm if d >= 0.0 else -v / norm)
