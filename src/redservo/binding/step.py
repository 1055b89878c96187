"""The public objects bound to one compiled control step (pure Python glue, no numba here).

:func:`compiled_step` takes the objects a user builds — a robot (the Afma6, a DH chain
such as the Panda, or a chain of fixed transforms and axes: a
:class:`~redservo.robots.chain.ChainRobot`, e.g. any URDF robot), a static scene, a visual task of image points or of moment features,
a law — and returns a :class:`CompiledStep`: the arguments of one kernel of
:mod:`redservo.kernels.step` packed once, so that each call runs kinematics, features,
``J1``, the law and its safety layer in compiled code. ``step(q, qdot_prev)`` gives the
same command as ``law(J1=..., e1=..., q=q, ...)`` after ``robot.kinematics`` and
``task.evaluate`` (to rounding), without any Python object per call. A batched closed
loop (many samples advanced together) calls the same kernels from compiled code.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.kernels import lazy
from redservo.limits import JointLimits
from redservo.packs import limits_pack
from redservo.redundancy.base import Law
from redservo.redundancy.bls import daqp_once
from redservo.redundancy.kio import law_options
from redservo.robots import Robot
from redservo.robots.afma6 import COUPLING, OFFSET, Afma6
from redservo.robots.chain import ChainRobot
from redservo.robots.dh import DHRobot
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import inverse
from redservo.task import VisualTask

__all__ = ["CompiledQPStep", "CompiledStep", "compiled_qp_step", "compiled_step", "robot_pack"]

_K = lazy("tasks")
_KC = lazy("chain_tasks")
_KQ = lazy("qp")


def _daqp() -> Any:
    """The daqp module (looked up once per process by the ``qp`` law's solvers)."""
    daqp = daqp_once()
    if daqp is None:
        raise ImportError("the compiled qp step needs daqp: pip install 'redservo[qp]'")
    return daqp


@dataclass(frozen=True)
class CompiledStep:
    """One control step as a kernel call: ``step(q, qdot_prev)`` returns the safe command.

    The command is a view of :attr:`out`, the buffer the kernel fills (layout in
    :func:`redservo.kernels.tasks.output_size`: ``q̇``, the law's integer and float
    diagnostics, the safety numbers, the level of each axis); it is overwritten by the
    next call, so copy it to keep it.
    """

    kernel: Callable[..., Any]
    """The kernel of :mod:`redservo.kernels.tasks`."""
    args: tuple[Any, ...]
    """The packs between ``q`` and ``qdot_prev`` (robot, task, law, limits; plain tuples,
    :mod:`redservo.kernels.tasks`), λ and dt, then a zero previous command."""
    task_kernel: Callable[..., Any]
    """The kernel computing ``(e1, J1)`` alone (kinematics and features) from ``q``, the
    robot pack and the task pack."""
    out: FloatArray
    """The output buffer the kernel fills."""

    def __call__(self, q: FloatArray, qdot_prev: FloatArray | None = None) -> FloatArray:
        prev = self.args[-1] if qdot_prev is None else qdot_prev
        self.kernel(q, *self.args[:-1], prev, qdot_prev is not None, self.out)
        return self.out[: q.shape[0]]

    def diagnostics(self, n: int) -> dict[str, FloatArray]:
        """Views of :attr:`out` after a call: ``iout``, ``fout``, ``sout``, ``levels``."""
        o = self.out
        return {
            "iout": o[n : n + 16],
            "fout": o[n + 16 : n + 32],
            "sout": o[n + 32 : n + 43],
            "levels": o[n + 43 : 2 * n + 43],
        }

    def task(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(e1, J1)`` at ``q``: the compiled kinematics and features of the step."""
        e1, J1 = self.task_kernel(q, self.args[0], self.args[1])
        return e1, J1


def robot_pack(robot: Robot) -> tuple[str, tuple[Any, ...]]:
    """``(kind, pack)``: the robot as the kernels take it (:mod:`redservo.kernels.tasks`),
    kind ``"afma6"``, ``"dh"`` or ``"chain"``.

    Raises:
        ConfigurationError: a robot without compiled kinematics.
    """
    eMc, cVe = np.ascontiguousarray(robot.eMc), np.ascontiguousarray(robot.cVe)
    if isinstance(robot, Afma6):
        return "afma6", (eMc, cVe, COUPLING, OFFSET)
    if isinstance(robot, DHRobot):
        return "dh", (
            robot._par,
            np.ascontiguousarray(robot._base),
            np.ascontiguousarray(robot._flange),
            robot.convention == "standard",
            eMc,
            cVe,
        )
    if isinstance(robot, ChainRobot):  # URDF robots included
        return "chain", (robot.chain.frames, robot.chain.joints, eMc, cVe)
    raise ConfigurationError(
        f"no compiled kinematics for {type(robot).__name__}; compiled robots: Afma6, DH chains "
        "and ChainRobot (URDF robots)",
        argument="robot",
    )


def _target(scene: Scene, task: VisualTask) -> tuple[FloatArray, list[Any]]:
    names = {t.target for t in task.terms}
    if len(names) != 1:
        raise ConfigurationError("a compiled step observes one scene object", argument="task")
    (name,) = names
    obj = scene.object(name)
    if not isinstance(obj, PointSet) or not isinstance(obj.trajectory, Static):
        raise ConfigurationError("a compiled step needs a static point set", argument="scene")
    bMo = inverse(scene.wMb) @ obj.trajectory.wMo
    return np.ascontiguousarray(bMo), [t.feature for t in task.terms]


def _points_kernels(kind: str) -> tuple[Callable[..., Any], Callable[..., Any]]:
    """The step and task kernels of an image-point task on a robot of this ``kind``."""
    if kind == "afma6":
        return _K.afma6_step, _K.afma6_points
    if kind == "dh":
        return _K.dh_step, _K.dh_points
    return _KC.chain_step, _KC.chain_points


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

    Supported: the Afma6, a DH robot or a :class:`~redservo.robots.chain.ChainRobot` (a
    URDF robot; image points only); a static :class:`~redservo.scene.PointSet`; a task
    of point features (current depth) or of one :class:`~redservo.features.MomentFeatures`;
    every law except ``qp`` (:data:`redservo.kernels.step.LAW_IDS`).

    Raises:
        ConfigurationError: a set-up the compiled step does not cover.
    """
    from redservo.features import MomentFeatures, PointFeature

    kind, robot_args = robot_pack(robot)
    bMo, feats = _target(scene, task)
    if task.depth != "current":
        raise ConfigurationError("a compiled step uses the current depth", argument="task")
    n = robot.n
    o = law_options(law, n)
    lp = limits_pack(limits)
    law_pack = (o.law_id, o.fopt, o.iopt, o.vopt)
    tail = (law_pack, (lp.rows, lp.has_v, lp.has_a), float(lam), float(dt), np.zeros(n))
    s_star = np.ascontiguousarray(task.s_star)
    if all(isinstance(f, PointFeature) for f in feats):
        pts = np.ascontiguousarray(np.array([f.point_o for f in feats]))
        C = np.eye(task.k) if task.C is None else np.ascontiguousarray(task.C)
        visual: tuple[Any, ...] = (bMo, pts, s_star, C)
        fn, task_fn = _points_kernels(kind)
    elif len(feats) == 1 and isinstance(feats[0], MomentFeatures) and task.C is None:
        f = feats[0]
        kinds = {"c4c6": 0, "pxpy": 1, "sxsy": 2}
        visual = (
            bMo,
            np.ascontiguousarray(f.points_o),
            f.desired_area,
            f.desired_depth,
            kinds[f.rotation_features],
            s_star,
        )
        if kind != "afma6":
            raise ConfigurationError("compiled moment steps exist for the Afma6", argument="robot")
        fn = _K.afma6_moments_step
        task_fn = _K.afma6_moments
    else:
        raise ConfigurationError(
            "a compiled step needs point features or one moment feature", argument="task"
        )
    from redservo.kernels.tasks import output_size

    return CompiledStep(fn, (robot_args, visual, *tail), task_fn, np.zeros(output_size(n)))


@dataclass(frozen=True)
class CompiledQPStep:
    """The ``qp`` step without Python objects per call: the compiled task, the kernel
    :func:`redservo.kernels.qp.qp_setup`, daqp on the reduced problem, then the kernel
    :func:`redservo.kernels.qp.qp_tail` (polish, checks, safety layer). Diagnostics are
    not built; ``step(q, qdot_prev)`` returns the safe command. Needs daqp (``redservo[qp]``)."""

    task: CompiledStep
    """The compiled task (its :meth:`CompiledStep.task` gives ``(e1, J1)``)."""
    law: Law
    """The ``qp`` law whose options are used."""
    limits: JointLimits
    lam: float
    dt: float

    def __call__(self, q: FloatArray, qdot_prev: FloatArray | None = None) -> FloatArray:
        daqp = _daqp()
        kq = _KQ
        e1, J1 = self.task.task(q)
        n = q.shape[0]
        lp = limits_pack(self.limits)
        z = np.zeros(n)
        prev = z if qdot_prev is None else qdot_prev
        has_prev = qdot_prev is not None
        o = vars(self.law)
        v = z if o["v_max"] is None else np.ascontiguousarray(np.broadcast_to(o["v_max"], (n,)))
        out = kq.qp_setup(
            J1, e1, q, lp.rows, lp.has_v, lp.has_a, self.dt, prev, has_prev, z, False,
            self.lam, o["k_p"], o["margin"], v, o["v_max"] is not None, self.law.rcond, o["eps"],
            self.law.shield,
        )  # fmt: skip
        qdot, inside, lo, hi, _, xdot, _, _, xfix, free, P, c, lof, hif = out
        xf = z[:0]
        if not inside and free.size:
            nf = free.size
            sense = np.zeros(nf, dtype=np.intc)
            xf = np.ascontiguousarray(daqp.solve(P, c, np.zeros((0, nf)), hif, lof, sense)[0])
        return np.asarray(
            kq.qp_tail(
                J1, xdot, lo, hi, bool(inside), qdot, xfix, free, xf, z, False,
                self.law.rcond, q, self.dt, lp.rows, lp.has_v, lp.has_a, prev, has_prev,
                self.law.shield,
            )
        )  # fmt: skip


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
