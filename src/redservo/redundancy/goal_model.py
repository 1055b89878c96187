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
from redservo.redundancy.predictive_model import PointModel
from redservo.redundancy.predictive_moments import MomentModel, moment_model
from redservo.redundancy.predictive_pnp import DotPoses
from redservo.redundancy.predictive_pose import PosePoints

__all__ = ["GoalModel", "Model"]

Model = PointModel | MomentModel
"""A global model of the task (image points, or the moments of one target)."""


class GoalModel:
    """The model of the current observation (module docstring): :meth:`observe` before each
    step, then :meth:`build` at the step's ``q`` (rad or m)."""

    def __init__(self) -> None:
        self.camera = Camera()
        """The camera whose intrinsics the PnP of the dots uses (the law's ``bind_camera``)."""
        self.dot_poses = DotPoses()
        self._pose = PosePoints()
        self._moments: MomentModel | None = None
        self._obs: Callable[[FloatArray, float], Model | None] | None = None

    def reset(self) -> None:
        """Forget the observation and the poses (start of a run)."""
        self._obs = None
        self._moments = None
        self._pose.reset()
        self.dot_poses.reset()

    def observe(self, robot: Any, task: Any, state: Any) -> None:
        """The Controller's hook: the model robot, the task and its evaluated state."""
        from redservo.features import MomentFeatures
        from redservo.features.point import PointFeature

        self._obs = None
        terms = task.terms
        if len({t.target for t in terms}) != 1:
            return
        if all(type(t.feature) is PointFeature for t in terms):
            points = self._pose.builder(robot, task, state)
            self._obs = lambda q, dt: points(q, None)
        elif len(terms) == 1 and type(terms[0].feature) is MomentFeatures:
            feature = terms[0].feature

            def build(q: FloatArray, dt: float) -> MomentModel | None:
                bMc = robot.kinematics(q, check_limits=False)[0]
                bMo = self.dot_poses.target_pose(robot, feature.points_o, q, dt, self.camera)
                prev = self._moments
                self._moments = moment_model(robot, feature, task, state, prev, bMc, bMo)
                return self._moments

            self._obs = build

    def build(self, q: FloatArray, dt: float) -> Model | None:
        """The model of the last observation at ``q`` (period ``dt``, s), once (None: no
        observation, or a task without a global model)."""
        obs, self._obs = self._obs, None
        return None if obs is None else obs(q, dt)
