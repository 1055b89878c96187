"""The start of a scenario with ``[[obstacles]]`` must be collision-free.

:func:`check_clear` raises one :class:`~redservo.errors.ScenarioError` naming the
obstacle's key and the pair in contact. A robot without a collision model (a URDF arm
without ``<collision>`` elements) is not checked: a :class:`UserWarning` says so, once per
build.
:func:`scenario_collision` builds the run's collision set-up from ``[collision]``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

from redservo._validation import FloatArray
from redservo.collision.query import distances
from redservo.collision.shapes import Obstacle
from redservo.errors import ConfigurationError
from redservo.robots.base import Robot
from redservo.scenario import Scenario

if TYPE_CHECKING:
    from redservo.control.avoidance import Collision

__all__ = ["check_clear", "scenario_collision"]


def check_clear(sc: Scenario, robot: Robot, q0: FloatArray, obstacles: Sequence[Obstacle]) -> None:
    """Raise if a link of ``robot`` at ``q0`` touches an obstacle at t = 0 (distance ≤ 0 m)
    or, with a ``[collision]`` table (enabled or not, so that a campaign draws the same starts
    with and without avoidance), lies closer to one than its ``d_safe``."""
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
    spec = sc.spec.collision
    d_safe = 0.0 if spec is None else spec.d_safe
    for rec in records:
        if rec.distance <= 0.0:
            raise sc.error(
                f"obstacles[{index[rec.second]}]",
                f"the start configuration is in collision: link {rec.first!r} and obstacle "
                f"{rec.second!r} overlap by {-rec.distance * 1000:.1f} mm",
            )
        if rec.distance < d_safe:
            raise sc.error(
                f"obstacles[{index[rec.second]}]",
                f"the start configuration is within collision.d_safe = {d_safe * 1000:.1f} mm: "
                f"link {rec.first!r} is {rec.distance * 1000:.1f} mm from obstacle "
                f"{rec.second!r} (no law could keep d_safe from there)",
            )


def scenario_collision(
    sc: Scenario, robot: Robot, q0: FloatArray, obstacles: Sequence[Obstacle]
) -> Collision | None:
    """The run's :class:`~redservo.control.avoidance.Collision` from ``[collision]`` and the
    obstacles: None when there is nothing to measure (or, without ``[collision]``, a robot
    without a collision model: :func:`check_clear` warned).

    Raises:
        ScenarioError: ``[collision]`` for a robot without a collision model
            (``collision.enabled``), or the self pairs in contact at ``q0``
            (``collision.self``).
    """
    from redservo.control.avoidance import Collision

    spec = sc.spec.collision
    if spec is None:
        coll = Collision(tuple(obstacles), enabled=False)
    else:
        values = spec.model_dump()
        values["self_collision"] = values.pop("self")
        coll = Collision(tuple(obstacles), **values)
    if not coll.active:
        return None
    try:
        coll.check_robot(robot)
    except ConfigurationError as exc:
        if spec is None:
            return None
        key = "collision.srdf" if exc.argument == "srdf" else "collision.enabled"
        raise sc.error(key, str(exc)) from None
    if coll.self_collision:
        own = Collision(self_collision=True, srdf=coll.srdf)
        pd = own.measure(robot, q0, 0.0)
        k = int(pd.d.argmin()) if pd.names else -1
        if k >= 0 and pd.d[k] <= 0.0:
            a, b = pd.names[k].split("/")
            raise sc.error(
                "collision.self",
                f"the start configuration is in self-collision: links {a!r} and {b!r} "
                f"overlap by {-pd.d[k] * 1000:.1f} mm",
            )
    return coll
