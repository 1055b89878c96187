"""The start of a scenario with ``[[obstacles]]`` must be collision-free.

:func:`check_clear` raises one :class:`~redservo.errors.ScenarioError` naming the
obstacle's key and the pair in contact. A robot without a built-in collision model (a
URDF arm, for now) is not checked: a :class:`UserWarning` says so, once per build.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

from redservo._validation import FloatArray
from redservo.collision.query import distances
from redservo.collision.shapes import Obstacle
from redservo.errors import ConfigurationError
from redservo.robots.base import Robot
from redservo.scenario import Scenario

__all__ = ["check_clear"]


def check_clear(sc: Scenario, robot: Robot, q0: FloatArray, obstacles: Sequence[Obstacle]) -> None:
    """Raise if a link of ``robot`` at ``q0`` touches an obstacle at t = 0 (distance ≤ 0 m)."""
    if not obstacles:
        return
    arm = getattr(robot, "carrier", robot)  # camera.mount = "world": the arm carrying the target
    try:
        records = distances(arm, q0, obstacles)
    except ConfigurationError as exc:
        warnings.warn(
            f"{sc.source}: obstacles are not checked against the robot: {exc}",
            UserWarning,
            stacklevel=2,
        )
        return
    index = {o.name: i for i, o in enumerate(obstacles)}
    for rec in records:
        if rec.distance <= 0.0:
            raise sc.error(
                f"obstacles[{index[rec.second]}]",
                f"the start configuration is in collision: link {rec.first!r} and obstacle "
                f"{rec.second!r} overlap by {-rec.distance * 1000:.1f} mm",
            )
