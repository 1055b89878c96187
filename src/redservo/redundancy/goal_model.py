"""The task model a joint-goal law searches its goal with: the ``predictive`` law's global
models (:mod:`redservo.redundancy.predictive_model`, :mod:`redservo.redundancy.predictive_moments`),
built from the :class:`~redservo.Controller`'s observation hook, without a horizon.

A task of image points of one target gives a :class:`~redservo.redundancy.predictive_model.PointModel`
whose points come from the target's pose estimated from the measured points
(:class:`~redservo.redundancy.predictive_pose.PosePoints`); the moment features of one target
give a :class:`~redservo.redundancy.predictive_moments.MomentModel` (its pose from the tracked
dots by PnP when a camera hands them over, :class:`~redservo.redundancy.predictive_pnp.DotPoses`).
Anything else (lines, several targets, a bare law call) gives no model: the law has no goal.
Units: metres, radians, normalized image coordinates.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.redundancy.predictive_model import PointModel, point_model
from redservo.redundancy.predictive_moments import MomentModel, moment_model
from redservo.redundancy.predictive_pnp import DotPoses
from redservo.redundancy.predictive_pose import PosePoints

__all__ = ["GoalModel", "Model", "Observation", "observation"]

Model = PointModel | MomentModel
"""A global model of the task (image points, or the moments of one target)."""


class GoalModel:
    """The model of the current observation (module docstring): :meth:`observe` before each
    step, then :meth:`build` at the step's ``q`` (rad or m). ``depth``: the point model's
    depths, ``"pose"`` (from the target's pose estimated from its known points) or
    ``"measured"`` (the sensor's); the ``predictive`` law builds its models through one of
    these too (its ``model_depth``)."""

    def __init__(self, depth: str = "pose") -> None:
        self.depth = depth
        self.camera = Camera()
        """The camera whose intrinsics the PnP of the dots uses (the law's ``bind_camera``)."""
        self.dot_poses = DotPoses()
        self.pose = PosePoints()
        self.moments: MomentModel | None = None
        """The last moment model built (the next one is warm-started from it)."""
        self._obs: Observation | None = None

    def reset(self) -> None:
        """Forget the observation and the poses (start of a run)."""
        self._obs = None
        self.moments = None
        self.pose.reset()
        self.dot_poses.reset()

    def observe(self, robot: Any, task: Any, state: Any) -> None:
        """The Controller's hook: the model robot, the task and its evaluated state."""
        self._obs = observation(self, robot, task, state)

    def build(self, q: FloatArray, dt: float, seen: FloatArray | None = None) -> Model | None:
        """The model of the last observation at ``q`` (period ``dt``, s; ``seen``: the
        joints when the image was exposed, None: ``q``), once (None: no observation, or a
        task without a global model)."""
        obs, self._obs = self._obs, None
        return None if obs is None else obs(q, seen, dt)


Observation = Callable[[FloatArray, "FloatArray | None", float], "Model | None"]
"""``build(q, seen, dt)``: the model of one observation (:func:`observation`)."""


def observation(parts: GoalModel, robot: Any, task: Any, state: Any) -> Observation | None:
    """The builder of the global model of the observation ``state`` of ``task`` (the model
    ``robot``), with the depths, camera, dot poses and previous moment model of ``parts``;
    None for a task without one (several targets, other features)."""
    from redservo.features import MomentFeatures
    from redservo.features.point import PointFeature

    terms = task.terms
    if len({t.target for t in terms}) != 1:
        return None
    if all(type(t.feature) is PointFeature for t in terms):
        if parts.depth != "pose":
            return lambda q, seen, dt: point_model(robot, task, state, q, seen)
        points = parts.pose.builder(robot, task, state)
        return lambda q, seen, dt: points(q, seen)
    if len(terms) == 1 and type(terms[0].feature) is MomentFeatures:
        feature, prev = terms[0].feature, parts.moments

        def build(q: FloatArray, seen: FloatArray | None, dt: float) -> MomentModel | None:
            bMc = robot.kinematics(q if seen is None else seen, check_limits=False)[0]
            bMo = parts.dot_poses.target_pose(robot, feature.points_o, q, dt, parts.camera)
            parts.moments = moment_model(robot, feature, task, state, prev, bMc, bMo)
            return parts.moments

        return build
    return None
