"""The controller: one object from a measurement to the safe joint command.

Every closed loop of redservo drives a :class:`Controller`: the simulator
(:func:`redservo.simulation.simulate`) and the servo loop of a real arm
(:class:`redservo.hardware.ServoLoop`) only supply time, measurements and actuation. One
:meth:`Controller.step` at time ``t`` with joint positions ``q`` and measured features:

1. **task**: ``e1 = C (s − s*)`` and ``J1 = C L(s, 1/Ẑ) J(q)`` with the controller's model
   (its robot's ``eMc`` is the hand-eye calibration, ``depth_scale`` the depth estimate's
   error) (:meth:`Controller.evaluate`);
2. **objectives** (:mod:`redservo.control.objectives`) add their joint commands into the
   law's ``secondary``; the first that ends the run wins: the step then carries its outcome
   in :attr:`ControlStep.stop` and no command is computed;
3. **feed-forward** ``∂e1/∂t`` (:mod:`redservo.control.feedforward`): ``"none"``,
   ``"estimated"`` from the controller's own previous step, or ``"known"`` from the scene's
   motion (the simulator's :class:`SceneContext`);
4. **law**: the command within the velocity/acceleration limits and (shield on) the
   position limits; any callable taking the law's keywords works (``de1_dt``, ``secondary``
   and ``qdot_prev`` are passed when it accepts them). A user's own law gets the servo
   loop's final guard on its output (:mod:`redservo.control.law_output`): a result without
   an (n,) ``qdot`` is one clear error, and a NaN, a command over the velocity or
   acceleration limits or (unless the law has ``shield = False``) past the safe range is
   corrected and flagged as a shipped law's safety layer does;
5. **output saturation** (``qdot_saturation``): the whole command scaled down uniformly
   (direction kept) so that no joint exceeds it, as a drive's saturation would;
6. **distance shield** (``collision``): the whole command scaled so that no collision pair
   comes closer than ``d_safe`` within one period
   (:func:`~redservo.control.avoidance.distance_shield`), flagged
   ``distance-shield-acted``.

**Engines** (:attr:`Controller.engine`). ``"compiled"``: the steps above run as one
compiled call (:mod:`redservo.binding.control`) when the set-up allows it (a task of image
points, a law with a compiled step, a fixed or adaptive gain, no objectives, no estimated
feed-forward), with the same command, task state and diagnostics bit for bit as the
object path. ``"kernels"``: the object path, each part a compiled kernel called from its
Python object. ``"python"``: a user's own law, feature or objective written in Python
takes part. :attr:`Controller.engine_reason` says why a step is not one compiled call.

Units: seconds, metres, radians; ``λ`` in 1/s; commands in rad/s or m/s per joint.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import cached_property
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_matrix, as_time, as_vector, is_float_vector
from redservo.control.avoidance import Collision, check_collision
from redservo.control.checks import check_controller, saturation
from redservo.control.engine import (
    QuickSetting,
    compiled_step,
    quick_ok,
    quick_step,
    setup_engine,
)
from redservo.control.feedforward import Feedforward, FeedforwardEstimator, known_feedforward
from redservo.control.image_motion import ImageMotionLimit, check_image_motion, point_rows
from redservo.control.latency import CommandHistory, present
from redservo.control.law_output import law_output
from redservo.control.objectives import Objective, ObjectiveContext
from redservo.control.output import final_guard, shape_output
from redservo.control.steps import ControlStep, Features, SceneContext
from redservo.errors import ConfigurationError, ShapeError
from redservo.limits import JointLimits
from redservo.redundancy.base import LawResult
from redservo.redundancy.gain import AdaptiveGain
from redservo.robots.base import Robot
from redservo.task import TaskState, VisualTask

__all__ = ["Controller"]


class Controller:
    """The control core every loop drives (see the module docstring).

    Args:
        robot: The controller's kinematic model: ``J(q) = cVe eJe(q)`` for ``J1`` (its
            ``eMc`` is the hand-eye calibration the controller believes in).
        task: The visual task (``s*``, ``C``, depth option).
        law: A control law (:func:`redservo.make_law`) or any callable taking the keywords
            ``J1, e1, q, limits, lam, dt`` (and, when it accepts them, ``de1_dt``,
            ``secondary``, ``qdot_prev``) and returning ``.qdot`` and ``.diagnostics``.
        limits: Joint limits given to the law (default: ``robot.limits()``).
        lam: Gain λ > 0 (1/s), or an :class:`~redservo.AdaptiveGain` λ(‖e1‖∞).
        dt: Control period (s) > 0, the law's ``dt``.
        objectives: Secondary objectives (:mod:`redservo.control.objectives`), summed in this
            order into the law's ``secondary`` (rad/s or m/s).
        feedforward: ``"none"``, ``"estimated"`` (from the previous step) or ``"known"`` (from
            the scene's motion: each step needs a :class:`SceneContext`).
        depth_scale: The depth the controller uses is ``Ẑ = depth_scale · Z`` (> 0).
        qdot_saturation: Output saturation after the law (rad/s or m/s, a number or (n,)):
            the command is scaled down uniformly so that no joint exceeds it. None: none.
        image_motion: The camera-motion limit (:class:`ImageMotionLimit`): the command is
            scaled down uniformly so that no image point moves further between two frames
            (or smears more during the exposure) than it allows; the final guard then keeps
            the acceleration limits. None: none.
        compensate_latency: Bring a measurement stamped before the step's ``t`` (a camera's
            latency, :attr:`Measurement.stamp`) to ``t`` with the commands sent since
            (:mod:`redservo.control.latency`); a measurement without a stamp is used as is.
            The commands sent, with their times, are in ``history`` (a ``CommandHistory``).
        engine: ``"auto"`` (default: compiled when the set-up allows it, module docstring),
            ``"compiled"`` (an error when it does not) or ``"python"`` (the object path,
            the reference).
        collision: A :class:`~redservo.control.avoidance.Collision`: unless it is off
            (``enabled`` or ``shield`` False), every command then passes the distance shield
            (step 6 of the module docstring). Its repulsion is an objective of its own
            (:class:`~redservo.control.avoidance.CollisionAvoidance`).

    Raises:
        ConfigurationError: an option is out of range, or the law cannot take what the
            options need (``secondary`` for objectives, ``de1_dt`` for a feed-forward);
            the error's ``argument`` names the option.
        ShapeError: ``limits`` or ``qdot_saturation`` do not match the robot's joints.
    """

    feedforward = QuickSetting[Feedforward]()
    """``"none"``, ``"estimated"`` or ``"known"`` (the constructor's argument)."""
    qdot_saturation = QuickSetting["FloatArray | None"]()
    """The output saturation (rad/s or m/s, (n,)), or None (the constructor's argument)."""
    image_motion = QuickSetting["ImageMotionLimit | None"]()
    """The camera-motion limit (:mod:`redservo.control.image_motion`), or None."""
    collision = QuickSetting["Collision | None"]()
    """The distance shield's set-up (:mod:`redservo.control.avoidance`), or None."""
    _plain_setup: bool
    """None of the four options above is set (:class:`~redservo.control.engine.QuickSetting`)."""

    def __init__(
        self,
        robot: Robot,
        task: VisualTask,
        law: Callable[..., LawResult],
        limits: JointLimits | None = None,
        *,
        lam: float | AdaptiveGain,
        dt: float,
        objectives: Sequence[Objective] = (),
        feedforward: Feedforward = "none",
        depth_scale: float = 1.0,
        qdot_saturation: float | ArrayLike | None = None,
        image_motion: ImageMotionLimit | None = None,
        compensate_latency: bool = True,
        engine: Literal["auto", "compiled", "python"] = "auto",
        collision: Collision | None = None,
    ) -> None:
        objs = tuple(objectives)
        self.accepts = check_controller(
            robot,
            task,
            law,
            limits,
            lam=lam,
            dt=dt,
            objectives=objs,
            feedforward=feedforward,
            depth_scale=depth_scale,
        )
        """The law's keywords (among ``J1 … dt, de1_dt, secondary, qdot_prev``)."""
        self.robot = robot
        self.task = task
        self.law = law
        self.limits: JointLimits = limits if limits is not None else robot.limits()
        self.lam = lam
        self.dt = float(dt)
        self.objectives: tuple[Objective, ...] = objs
        self.feedforward = feedforward
        self.depth_scale = float(depth_scale)
        self.qdot_saturation = saturation(qdot_saturation, robot.n)
        self.image_motion = check_image_motion(image_motion)
        self._motion_rows = point_rows(task) if image_motion is not None else ()
        self.collision = check_collision(collision, robot, law)
        self._estimator = FeedforwardEstimator(self.dt) if feedforward == "estimated" else None
        self.compensate_latency = bool(compensate_latency)
        self.history = CommandHistory(self.dt, lambda q: robot.jacobian(q, check_limits=False))
        self._observe = getattr(law, "observe", None)  # a predictive law's model hook
        self._engine_asked = engine
        self._compiled, self._python, self.engine_reason = setup_engine(self, engine)
        """Why :meth:`step` is not one compiled call (one line), or ``""``."""
        self._own_law = any(part.startswith("law ") for part in self._python)
        """The law is a user's own: its output goes through the final guard."""
        self.stage = "task"
        """The part of the step running, or that raised: ``"task"``, ``"objectives"``,
        ``"feed-forward"``, ``"law"``, ``"guard"`` or ``"saturation"`` (a loop names it in
        its errors)."""

    @property
    def engine(self) -> str:
        """The engine of :meth:`step`: ``"compiled"`` (one compiled call), ``"kernels"`` (the
        object path: each part a compiled kernel called from Python) or ``"python"`` (a
        user's own law, feature or objective written in Python takes part)."""
        if self._compiled is not None:
            return "compiled"
        return "python" if self._python else "kernels"

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.robot.n

    @cached_property
    def _quick(self) -> bool:
        """:meth:`step` may try :func:`~redservo.control.engine.quick_step` first (read
        once: the engine is bound at construction)."""
        return quick_ok(self._compiled)

    def rebind(self) -> None:
        """Bind the compiled engine anew (a law whose options changed since: its step would
        use the old ones). A step does it when it sees the change.

        Raises:
            ConfigurationError: ``engine="compiled"`` and the law's new options have no
                compiled step (``argument="engine"``).
        """
        self._compiled, self._python, self.engine_reason = setup_engine(self, self._engine_asked)
        self._own_law = any(part.startswith("law ") for part in self._python)
        self.__dict__.pop("_quick", None)

    @cached_property
    def _n(self) -> int:
        """Number of joints, read once (the step's hot path)."""
        return self.robot.n

    def __repr__(self) -> str:
        name = getattr(self.law, "name", None) or type(self.law).__name__
        return (
            f"Controller({type(self.robot).__name__}, law={name!r}, lam={self.lam!r}, "
            f"dt={self.dt!r}, objectives={len(self.objectives)}, "
            f"feedforward={self.feedforward!r})"
        )

    def reset(self) -> None:
        """Reset the law, every objective with a ``reset()`` and the feed-forward estimate
        (start of a run: two identical runs then give identical commands)."""
        parts: tuple[object, ...] = (self.law, *self.objectives)
        for part in parts:
            reset = getattr(part, "reset", None)
            if callable(reset):
                reset()
        if self._estimator is not None:
            self._estimator.reset()
        self.history.reset()

    # -- one step ------------------------------------------------------------------------------

    def step(
        self,
        q: ArrayLike,
        measurement: Features,
        t: float,
        *,
        qdot_prev: ArrayLike | None,
        J: ArrayLike | None = None,
        context: SceneContext | None = None,
    ) -> ControlStep:
        """Turn a measurement into the safe command: :meth:`evaluate` then :meth:`command`.

        Args:
            q: (n,) measured joint positions (m or rad), within ``limits``.
            measurement: The features ``s`` (k,) and their inverse-depth parameters per term.
            t: Time of the step (s) since the start of the run: a finite number (a
                string or a boolean is refused). A measurement with a ``stamp`` earlier than
                ``t`` (a camera's latency) is brought to ``t`` (``compensate_latency``).
            qdot_prev: (n,) the command applied since the previous step (rad/s or m/s): the
                law's acceleration limits and the estimated feed-forward use it; None (e.g.
                a first call with unknown motion) leaves both out. Zeros for a robot at rest.
            J: (6, n) the model Jacobian at ``q`` when the caller has it (else computed).
            context: The scene and true camera pose (simulator only), for the objectives
                and the ``"known"`` feed-forward.

        Returns:
            :class:`ControlStep`.

        Raises:
            GeometryError: a feature cannot be evaluated (the task's own check).
            ShapeError: ``q``, ``J``, ``t`` or the measurement do not fit the robot and task
                (a None measurement included), or a user's own law returned no (n,)
                ``qdot``.
            ConfigurationError: ``"known"`` feed-forward without a context, or an objective
                that needs the scene without one.
        """
        if self._quick and J is None:  # the step a loop repeats: one call around the kernel
            done = quick_step(self, q, measurement, t, qdot_prev)
            if done is not None:
                return done
        t = as_time(t, "t")
        if self.compensate_latency and getattr(measurement, "stamp", None) is not None:
            s = self._measured_s(measurement)
            measurement = present(
                self.task, self.history, measurement, t, s, self.depth_scale, self._compiled
            )
        if self._compiled is not None and is_float_vector(q, self._n):  # the kernel checks values
            done = compiled_step(self, cast(FloatArray, q), measurement, t, qdot_prev, J, context)
            if done is not None:
                return done  # its command is in the history already
        qa = as_vector(q, "q", self._n)
        Ja = self.jacobian(qa, J)
        state = self.evaluate(measurement, Ja)
        done = self._command(qa, state, t, qdot_prev=qdot_prev, J=Ja, context=context)
        self.history.record(t, qa, done.qdot)
        return done

    def jacobian(self, q: FloatArray, J: ArrayLike | None = None) -> FloatArray:
        """The model Jacobian (6, n) at ``q``: ``J`` checked when given, else computed."""
        if J is None:
            return self.robot.jacobian(q, check_limits=False)
        Ja = as_matrix(J, "J")
        if Ja.shape != (6, self.robot.n):
            raise ShapeError(f"J must have shape (6, {self.robot.n}), got {Ja.shape}", argument="J")
        return Ja

    def evaluate(self, measurement: Features, J: FloatArray) -> TaskState:
        """The task state (``e1``, ``J1``, ...) from a measurement and the model Jacobian
        ``J`` (6, n), with the controller's ``depth_scale``.

        Raises:
            ShapeError: ``s`` is not (k,) or ``inv_depth`` has not one entry per task term.
            GeometryError: a feature cannot be evaluated.
        """
        self.stage = "task"
        s = self._measured_s(measurement)
        return self.task.evaluate_measured(
            s, measurement.inv_depth, J, depth_scale=self.depth_scale
        )

    def _measured_s(self, measurement: Features) -> FloatArray:
        """The measurement's ``s`` (k,), its shape and its inverse depths' count checked."""
        if not (hasattr(measurement, "s") and hasattr(measurement, "inv_depth")):
            raise ShapeError(
                f"measurement must have .s ({self.task.k},) and .inv_depth (one entry per task "
                f"term), e.g. redservo.control.Measurement; got {type(measurement).__name__}",
                argument="measurement",
            )
        s = as_vector(measurement.s, "measurement.s")
        if s.shape != (self.task.k,):
            raise ShapeError(
                f"measurement.s must have shape ({self.task.k},), got {s.shape}",
                argument="measurement.s",
            )
        if not hasattr(measurement.inv_depth, "__len__") or len(measurement.inv_depth) != len(
            self.task.terms
        ):
            raise ShapeError(
                f"measurement.inv_depth must hold one entry per task term "
                f"({len(self.task.terms)}), got {measurement.inv_depth!r:.80}",
                argument="measurement.inv_depth",
            )
        return s

    def command(
        self,
        q: FloatArray,
        state: TaskState,
        t: float,
        *,
        qdot_prev: ArrayLike | None,
        J: FloatArray | None = None,
        context: SceneContext | None = None,
    ) -> ControlStep:
        """Objectives, feed-forward, law and saturation on an evaluated task ``state``
        (arguments as in :meth:`step`)."""
        return self._command(q, state, as_time(t, "t"), qdot_prev=qdot_prev, J=J, context=context)

    def _command(
        self,
        q: FloatArray,
        state: TaskState,
        t: float,
        *,
        qdot_prev: ArrayLike | None,
        J: FloatArray | None = None,
        context: SceneContext | None = None,
    ) -> ControlStep:
        """:meth:`command` with ``t`` already checked (by :meth:`step` or :meth:`command`)."""
        prev = None if qdot_prev is None else np.asarray(qdot_prev, dtype=float)
        secondary: FloatArray | None = None
        if self.objectives:
            self.stage = "objectives"
            Ja = self.jacobian(q) if J is None else J
            ctx = ObjectiveContext(
                None if context is None else context.scene,
                None if context is None else context.bMc,
                Ja,
                q,
                self.limits,
                state,
                t,
                self.robot,
            )
            secondary, stop = self.secondary(ctx)
            if stop is not None:
                return ControlStep(np.zeros(self.robot.n), state, None, None, None, stop, False)
        self.stage = "feed-forward"
        de1_dt = self._feedforward(state, t, prev, context)
        self.stage = "law"
        if self._observe is not None:
            self._observe(self.robot, self.task, state)
        res = self.law(**self._law_kwargs(state, q, de1_dt, secondary, prev))
        if self._own_law:
            self.stage = "guard"
            qdot, diag = final_guard(self, *law_output(res, self.law, self.robot.n), q, prev)
        else:
            qdot, diag = res.qdot, res.diagnostics
        qdot, diag, saturated = shape_output(self, qdot, diag, state, q, J, t, prev)
        if self._estimator is not None:
            self._estimator.record(state, t)
        return ControlStep(qdot, state, diag, secondary, de1_dt, None, saturated)

    def secondary(self, ctx: ObjectiveContext) -> tuple[FloatArray | None, str | None]:
        """Sum the objectives' commands (n,), in order; the first that ends the run wins
        (``(None, outcome)``)."""
        total: FloatArray | None = None
        for obj in self.objectives:
            cmd, stop = obj(ctx)
            if stop is not None:
                return None, stop
            if cmd is not None:
                total = cmd if total is None else total + cmd
        return total, None

    def _feedforward(
        self,
        state: TaskState,
        t: float,
        qdot_prev: FloatArray | None,
        context: SceneContext | None,
    ) -> FloatArray | None:
        if self._estimator is not None:
            return self._estimator.estimate(state, t, qdot_prev)
        if self.feedforward == "known":
            return self._feedforward_known(t, context)
        return None

    def _feedforward_known(self, t: float, context: SceneContext | None) -> FloatArray:
        if context is None:
            raise ConfigurationError(
                "feedforward='known' needs the scene's motion: pass context="
                "SceneContext(scene, bMc) to each step, or use 'estimated'",
                argument="feedforward",
            )
        return known_feedforward(self.task, context.scene, context.bMc, t, self.dt)

    def _law_kwargs(
        self,
        state: TaskState,
        q: FloatArray,
        de1_dt: FloatArray | None,
        secondary: FloatArray | None,
        qdot_prev: FloatArray | None,
    ) -> dict[str, Any]:
        kw: dict[str, Any] = {
            "J1": state.J1,
            "e1": state.e1,
            "q": q,
            "limits": self.limits,
            "lam": self.lam,
            "dt": self.dt,
        }
        for name, value in (("de1_dt", de1_dt), ("secondary", secondary), ("qdot_prev", qdot_prev)):
            if name in self.accepts:
                kw[name] = value
        return kw
