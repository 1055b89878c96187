"""Collision geometry and distances (issue 30 items 1 and 2).

* :mod:`~redservo.collision.shapes`: primitives and moving obstacles (world frame).
* :mod:`~redservo.collision.robot`: the built-in robots' capsules, link-point Jacobians.
* :mod:`~redservo.collision.pairs`: self-collision pairs and their exclusions.
* :mod:`~redservo.collision.query`: :func:`distances`, the user-facing query.
* :mod:`~redservo.collision.urdf`: a URDF's ``<collision>`` elements as coal geometries.

Distances come from `coal` (installed with Pinocchio 3); docs/collision.md. Avoidance (the
repulsive objective and the distance shield) is :mod:`redservo.control.avoidance`.
"""

from redservo.collision.pairs import self_pairs
from redservo.collision.query import DistanceRecord, distances
from redservo.collision.robot import LinkCapsule, link_capsules
from redservo.collision.shapes import SHAPES, Obstacle, Shape
from redservo.collision.urdf import UrdfCollision, urdf_collisions

__all__ = [
    "SHAPES",
    "DistanceRecord",
    "LinkCapsule",
    "Obstacle",
    "Shape",
    "UrdfCollision",
    "distances",
    "link_capsules",
    "self_pairs",
    "urdf_collisions",
]
