"""The public objects bound to the step kernel for benchmarks (pure Python glue, no numba here).

:func:`compiled_step` takes the objects a user builds (a robot with compiled kinematics, a
scene of point sets, a task of image points or moment features, a law) and returns a
:class:`CompiledStep`: the packs of :func:`redservo.kernels.sensed.sensed_step` made once,
so that each call runs the kinematics, the ideal sensor, CM01 eq. 25, the law and its
safety layer in compiled code, with no Python object per call. It is the same step
kernel (:mod:`redservo.kernels.control`) that the campaign loop runs at every iteration
and the :class:`~redservo.control.Controller` runs on measured points; no copy of the step
lives here. ``step(q, qdot_prev)`` gives the command of ``law(J1=..., e1=..., q=q, ...)``
after ``robot.kinematics`` and ``task.evaluate``, bit for bit. :func:`compiled_qp_step`
adds ``qp``'s compiled solver (:mod:`redservo.kernels.boxqp`) between two kernels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.binding.packs import scene_pack, task_pack
from redservo.errors import ConfigurationError
from redservo.kernels import lazy
from redservo.limits import JointLimits
from redservo.redundancy.base import Law
from redservo.redundancy.kio import law_options
from redservo.redundancy.packs import limits_pack
from redservo.robots import Robot
from redservo.scene import Scene
from redservo.task import VisualTask

__all__ = ["CompiledQPStep", "CompiledStep", "compiled_qp_step", "compiled_step"]

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import boxqp as _KB
    from redservo.kernels import qp as _KQ
    from redservo.kernels import sensed as _KS
else:
    _KS = lazy("sensed")
    _KQ = lazy("qp")
    _KB = lazy("boxqp")


@dataclass(frozen=True)
class CompiledStep:
    """One control step as a call of the step kernel: ``step(q, qdot_prev)`` returns the safe
    command.

    The step is :func:`redservo.kernels.sensed.sensed_step`: the robot's kinematics, the
    ideal sensor, CM01 eq. 25 and the law with its safety layer, the kernels that the
    campaign loop runs at each iteration and the Controller runs on measured points (one
    step kernel, :mod:`redservo.kernels.control`).
    """

    robot: tuple[Any, ...]
    """The robot pack (:mod:`redservo.robots.pack`)."""
    scene: tuple[Any, ...]
    task_pack: tuple[Any, ...]
    law: tuple[Any, ...]
    limits: tuple[Any, ...]
    sim: tuple[Any, ...]
    zero: FloatArray
    """(n,) zeros (an empty slice of it: no previous command)."""

    def __call__(self, q: FloatArray, qdot_prev: FloatArray | None = None) -> FloatArray:
        prev = self.zero[:0] if qdot_prev is None else qdot_prev  # empty: no previous command
        qd, _, _, _, ok = _KS.sensed_step(
            q, prev, self.robot, self.scene, self.task_pack, self.law, self.limits, self.sim
        )
        if not ok:
            raise ConfigurationError(
                "the compiled step cannot run at this q (a feature is lost or an input is not "
                "finite): use the Controller, whose checks name the input",
                argument="q",
            )
        return np.asarray(qd)

    def task(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(e1, J1)`` at ``q``: the compiled kinematics, ideal sensor and CM01 eq. 25."""
        _, e1, J1, _, _, _, _ = _KS.sense(0, q, self.robot, self.scene, self.task_pack, self.sim)
        return e1, J1


def _robot_pack(robot: Robot) -> tuple[Any, ...]:
    pack = robot.kernel_pack()
    if pack is None:
        raise ConfigurationError(
            f"no compiled kinematics for {type(robot).__name__}; compiled robots: Afma6, DH "
            "chains and ChainRobot (URDF robots)",
            argument="robot",
        )
    return pack


def compiled_step(
    robot: Robot,
    scene: Scene,
    task: VisualTask,
    law: Law,
    *,
    limits: JointLimits,
    lam: float,
    dt: float,
) -> CompiledStep:
    """Pack the arguments of the compiled step of this set-up (module docstring).

    Supported: the robots with compiled kinematics (the Afma6, DH robots, chains such as
    URDF robots); point sets, static or on waypoints; tasks of image points and moment
    features with the current depth; every law of
    :data:`redservo.kernels.step.LAW_IDS` (``qp``: :func:`compiled_qp_step`).

    Raises:
        ConfigurationError: a set-up the compiled step does not cover.
    """
    from redservo.camera import Camera
    from redservo.features import MomentFeatures, PointFeature
    from redservo.scene import PointSet, Static, Waypoints

    if task.depth != "current":
        raise ConfigurationError("a compiled step uses the current depth", argument="task")
    for term in task.terms:
        obj = scene.object(term.target)
        if type(term.feature) not in (PointFeature, MomentFeatures):
            raise ConfigurationError(
                "a compiled step needs point features or moment features", argument="task"
            )
        if not isinstance(obj, PointSet) or type(obj.trajectory) not in (Static, Waypoints):
            raise ConfigurationError(
                "a compiled step needs point sets, static or on waypoints", argument="scene"
            )
    n = robot.n
    o = law_options(law, n)
    lp = limits_pack(limits)
    has_cap = getattr(law, "alpha_max", None) is not None
    sim = (float(lam), float(dt), 0.0, True, np.ones(n), False, False)
    return CompiledStep(
        robot=_robot_pack(robot),
        scene=scene_pack(scene, task, Camera(), 0.0, False),
        task_pack=task_pack(task, 1.0),
        law=(o.law_id, o.fopt, o.iopt, o.vopt, has_cap),
        limits=(lp.rows, lp.has_v, lp.has_a, np.array(limits.q_min), np.array(limits.q_max)),
        sim=sim,
        zero=np.zeros(n),
    )


@dataclass(frozen=True)
class CompiledQPStep:
    """The ``qp`` step without Python objects per call: the compiled task, the kernel
    :func:`redservo.kernels.qp.qp_setup`, the compiled solver on the reduced problem
    (:func:`redservo.kernels.boxqp.box_qp`, the law's ``"auto"`` solver), then the kernel
    :func:`redservo.kernels.qp.qp_tail` (polish, checks, safety layer). Diagnostics are
    not built; ``step(q, qdot_prev)`` returns the safe command. Where the solver fails, the
    law object gives the command (its fallback)."""

    task: CompiledStep
    """The compiled task (its :meth:`CompiledStep.task` gives ``(e1, J1)``)."""
    law: Law
    """The ``qp`` law whose options are used."""
    limits: JointLimits
    lam: float
    dt: float

    def __call__(self, q: FloatArray, qdot_prev: FloatArray | None = None) -> FloatArray:
        e1, J1 = self.task.task(q)
        n = q.shape[0]
        lp = limits_pack(self.limits)
        z = np.zeros(n)
        prev = z if qdot_prev is None else qdot_prev
        has_prev = qdot_prev is not None
        law = self.law
        o = vars(law)
        v = z if o["v_max"] is None else np.ascontiguousarray(np.broadcast_to(o["v_max"], (n,)))
        kq: Any = _KQ  # argument packs below, as the qp law's own call writes them out
        rates = (lp.rows, lp.has_v, lp.has_a, self.dt, prev, has_prev)
        opts = (self.lam, o["k_p"], o["margin"], v, o["v_max"] is not None, law.rcond, o["eps"])
        out = kq.qp_setup(J1, e1, q, *rates, z, False, *opts, law.shield)
        qdot, inside, lo, hi, _, xdot, _, _, xfix, free, P, c, lof, hif = out
        xf = z[:0]
        if not inside and free.size:
            xf, status, _ = _KB.box_qp(P, c, lof, hif)
            if status != _KB.SOLVED:
                kw: dict[str, Any] = {"limits": self.limits, "lam": self.lam, "dt": self.dt}
                return law(J1=J1, e1=e1, q=q, qdot_prev=qdot_prev, **kw).qdot
        found = (J1, xdot, lo, hi, bool(inside), qdot, xfix, free, xf, z, False, law.rcond)
        tail = (q, self.dt, lp.rows, lp.has_v, lp.has_a, prev, has_prev)
        return np.asarray(kq.qp_tail(*found, *tail, law.shield))


def compiled_qp_step(
    robot: Robot,
    scene: Scene,
    task: VisualTask,
    law: Law,
    *,
    limits: JointLimits,
    lam: float,
    dt: float,
) -> CompiledQPStep:
    """:class:`CompiledQPStep` for a ``qp`` law (set-ups as :func:`compiled_step`).

    Raises:
        ConfigurationError: ``law`` is not ``qp``, or a set-up :func:`compiled_step` rejects.
    """
    if law.name != "qp":
        raise ConfigurationError("compiled_qp_step needs the 'qp' law", argument="law")
    from redservo.redundancy import make_law

    inner = compiled_step(robot, scene, task, make_law("classical"), limits=limits, lam=lam, dt=dt)
    return CompiledQPStep(inner, law, limits, float(lam), float(dt))
