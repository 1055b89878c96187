"""The campaign loop's iteration at one configuration, for the benchmarks (no kernel of its own).

:func:`sensed_iteration` packs a benchmark set-up (robot, scene, task, law, limits) the way the
campaign packs an experiment (:mod:`redservo.campaign.looppack`,
:func:`redservo.campaign.looplaw.law_args`) and returns a :class:`SensedIteration`: each call
runs the kernels that :func:`redservo.campaign.loop_kernel.closed_loop` runs at every
iteration, :func:`redservo.kernels.sensed.sense` (the robot's kinematics, the ideal sensor,
CM01 eq. 25 by the step kernel's :func:`~redservo.kernels.control.task_rows`) then
:func:`~redservo.kernels.sensed.law_bits_sec` (the step kernel's
:func:`~redservo.kernels.control.law_core`: the law and its safety layer) or, for ``qp``,
:func:`~redservo.kernels.sensed.qp_law` (its compiled solver; where it hands the step back,
the law object computes it, as in the campaign). It is a driver of the one step kernel
(docs/architecture.md), not a copy of it: ``redservo bench`` times it as the "compiled"
path and the tests compare it with the object path. Units: m, rad, s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple, cast

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.limits import JointLimits
from redservo.redundancy.base import Law
from redservo.robots import Robot
from redservo.scene import Scene
from redservo.task import VisualTask

if TYPE_CHECKING:
    from redservo.experiment.build import Experiment

__all__ = ["SensedIteration", "sensed_iteration"]


class _SetUp(NamedTuple):
    """The parts of an experiment the campaign's coverage checks read."""

    robot: Robot
    scene: Scene
    task: VisualTask


@dataclass(frozen=True)
class SensedIteration:
    """One iteration of the campaign loop at ``q`` (module docstring): ``step(q, qdot_prev)``
    returns the safe command (rad/s or m/s per joint)."""

    robot: tuple[Any, ...]
    """The robot pack (:meth:`redservo.robots.Robot.kernel_pack`)."""
    scene: tuple[Any, ...]
    task_pack: tuple[Any, ...]
    law_pack: tuple[Any, ...]
    limits_pack: tuple[Any, ...]
    sim: tuple[Any, ...]
    law: Law
    limits: JointLimits
    solve: tuple[Any, ...]
    """``qp``'s hand-back buffers (:func:`redservo.kernels.sensed.qp_law`)."""

    def task(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(e1, J1)`` at ``q``: the compiled kinematics, ideal sensor and CM01 eq. 25."""
        from redservo.kernels.sensed import sense

        _, e1, J1, _, _, _, _ = sense(0, q, self.robot, self.scene, self.task_pack, self.sim)
        return e1, J1

    def __call__(self, q: FloatArray, qdot_prev: FloatArray | None = None) -> FloatArray:
        from redservo.kernels.sensed import QP, law_bits_sec, qp_law, sense

        sim = self.sim
        _, e1, J1, ff, has_ff, outcome, abort = sense(
            0, q, self.robot, self.scene, self.task_pack, sim
        )
        if outcome >= 0:
            raise ConfigurationError(
                "the campaign's iteration cannot run at this q (a feature is lost or an input "
                "is not finite): use the Controller, whose checks name the input",
                argument="q",
            )
        if self.law_pack[0] == QP:  # the campaign's qp step always has a previous command
            prev = np.zeros(q.shape[0]) if qdot_prev is None else qdot_prev
            qd, _, need = qp_law(
                J1, e1, ff, has_ff, q, prev, self.law_pack, self.limits_pack, sim, self.solve
            )
            if need:  # the law's own solver, as the campaign hands it the step
                kw = {"limits": self.limits, "lam": sim[0], "dt": sim[1]}
                return self.law(J1=J1, e1=e1, q=q, qdot_prev=prev, **kw).qdot
            return np.asarray(qd)
        none = q[:0]  # an empty previous command: none
        prev = none if qdot_prev is None else qdot_prev
        packs = (self.law_pack, self.limits_pack, sim, none)  # no secondary
        qd, _, _, abort = law_bits_sec(J1, e1, ff, has_ff, q, prev, none, False, *packs)
        if abort:
            raise ConfigurationError(
                f"the law {self.law.name!r} would raise at this q: use its call, whose error "
                "names the input",
                argument="q",
            )
        return np.asarray(qd)


def sensed_iteration(
    robot: Robot,
    scene: Scene,
    task: VisualTask,
    law: Law,
    *,
    limits: JointLimits,
    lam: float,
    dt: float,
) -> SensedIteration:
    """Pack the campaign loop's arguments for this set-up (module docstring); ``lam`` (1/s)
    the gain, ``dt`` (s) the period.

    Raises:
        ConfigurationError: a set-up the campaign loop does not cover (the campaign's reason).
    """
    from redservo.binding.packs import scene_pack, task_pack
    from redservo.camera import Camera
    from redservo.campaign.looplaw import law_args
    from redservo.campaign.looppack import robot_reason, scene_reason
    from redservo.redundancy.packs import limits_pack

    setup = cast("Experiment", _SetUp(robot, scene, task))
    why = robot_reason(setup) or scene_reason(setup)
    if why is not None:
        raise ConfigurationError(f"not covered by the campaign loop: {why}", argument="robot, task")
    m, n = task.m, robot.n
    lp = limits_pack(limits)
    pend = np.zeros(4, dtype=np.int64)
    return SensedIteration(
        robot=cast(tuple[Any, ...], robot.kernel_pack()),
        scene=scene_pack(scene, task, Camera(), 0.0, False),
        task_pack=task_pack(task, 1.0),
        law_pack=law_args(law, n),
        limits_pack=(lp.rows, lp.has_v, lp.has_a, np.array(limits.q_min), np.array(limits.q_max)),
        sim=(float(lam), float(dt), 0.0, True, np.ones(n), False, False),
        law=law,
        limits=limits,
        solve=(np.zeros((m, n)), np.zeros(m), np.zeros(n), pend, np.zeros(m)),
    )
