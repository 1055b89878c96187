"""Predictive (model predictive) visual servoing under joint limits and visibility.

Allibert, Courtial & Chaumette, "Predictive control for constrained image-based visual
servoing", IEEE T-RO 26(5), 2010 (docs/predictive.md). At each period::

    min_U  Σ_{k=1..N} ‖e_k(U)‖² / N + ρ ‖U − Ū‖² + γ ‖q_N − q*‖²
    s.t.   |u_j| <= q̇_max,   |u_0 - q̇_prev| <= q̈_max dt,   |u_j - u_{j-1}| <= q̈_max dt
           q_min + margin Δq <= q_k <= q_max - margin Δq          (k = 1…N)
           image points inside the image less ``image_margin_px``   (k = 1…N, global model)

with ``U`` the joint velocities of ``control_horizon`` blocks over ``horizon`` periods
(:mod:`redservo.redundancy.predictive_model`); the first block ``u_0`` is the command.

Decisions (the paper is silent or differs; docs/decisions.md, "predictive"):

* **Model**: ``model="global"`` predicts with the model robot's kinematics and the target:
  its points (a task of image points of one target) or its pose estimated from the moment
  features (:mod:`redservo.redundancy.predictive_moments`); the :class:`~redservo.Controller`
  calls :meth:`Predictive.observe` before each step. Otherwise (a bare law call, lines...)
  the local model with the constant ``J1``, and ``info`` says so; ``model="local"`` forces it.
* **Solver**: sequential QP, ``sqp_iterations`` (default 1: the real-time iteration,
  linearised at the previous solution shifted by one period, the warm start) on ``daqp``.
* **Cost**: the reference is ``e = 0`` at every predicted period (Allibert 2010 track
  ``s*``); ``ρ = effort · dt² σ_max(J1)²`` damps the step from ``Ū``; the joint goal ``q*``
  (:mod:`redservo.redundancy.predictive_goal`) is weighted by ``γ = goal_weight σ_max(J1)²``;
  a known feed-forward ``∂e1/∂t`` drifts the predicted errors by ``k dt ∂e1/∂t``.
* **Relaxed bounds**: a joint (or image point) already inside its band may stay where it is
  but not go deeper: its bound is relaxed to the current value.
* **Fallback**: if daqp reports an infeasible horizon (flag ``horizon-infeasible``), hits its
  iteration limit or the step exceeds ``time_budget`` (flag ``solver-iterations``), or gives
  a non-finite result, the command is the ``qp`` law's (with the same margin), and
  ``solver-fallback`` is raised; the next solve starts from ``qdot_prev``. ``time_budget =
  None`` (default) disables the clock, so that simulations and campaigns do not depend on
  the machine; a real servo loop sets it below its period.
* **Safety**: the first block also lies in the shield's box (its braking bound) and the
  command goes through the same safety stage as every law: a no-op in the usual case.

State kept between calls (``stateful``): the last solution ``U`` (the warm start), the joint
goal and its search, the moment model's target pose and the task observation of the current
step; :meth:`reset` clears them.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.kernels import flagbits as fb
from redservo.limits import JointLimits
from redservo.redundancy.base import (
    Diagnostics,
    Law,
    LawInputs,
    LawResult,
    register,
)
from redservo.redundancy.flags import FLAGS
from redservo.redundancy.goal_model import GoalModel, observation
from redservo.redundancy.predictive_budget import LOOP_SHARE, Deadline, fallback_result, warm_up
from redservo.redundancy.predictive_camera import (
    MotionGain,
    MotionLimit,
    limited,
)
from redservo.redundancy.predictive_distance import goal_clearance, static_scene
from redservo.redundancy.predictive_goal import GoalSearch, better_goal
from redservo.redundancy.predictive_model import (
    QP,
    PointModel,
    SeenJoints,
    horizon,
)
from redservo.redundancy.predictive_moments import MomentModel
from redservo.redundancy.predictive_options import OPTIONS
from redservo.redundancy.predictive_qp import horizon_qp, solve_horizon
from redservo.redundancy.predictive_replan import Replan, SeedMemo, model_key

__all__ = ["Predictive"]

_BIT = {f: j for j, f in enumerate(FLAGS)}
Model = PointModel | MomentModel
"""A global prediction model (image points, or the moment features of one target)."""
GOAL_RANDOM_SEEDS = 60
"""Seeds drawn uniformly within the bounds after the seven near ``q`` (joint-goal search)."""


@register
class Predictive(Law):
    """Model predictive control over a horizon (Allibert, Courtial & Chaumette 2010).

    See the module docstring for the formulation, the models and the fallback.
    """

    name = "predictive"
    description = "model predictive control over N periods, joint limits + visibility (ACC 2010)"
    stateful = True

    OPTIONS = OPTIONS
    horizon: int
    control_horizon: int
    model: str
    effort: float
    margin: float
    image_margin_px: float
    goal_weight: float
    replan: int
    goal_steps: int
    sqp_iterations: int
    max_qp_iterations: int
    time_budget: float | None
    max_image_motion: float | None
    max_image_motion_px: float | None
    frame_rate: float | None
    latency: float
    model_depth: str

    def _setup(self) -> None:
        from redservo.redundancy.base import make_law

        self._hz = horizon(self.horizon, self.control_horizon)
        self._fallback = make_law("qp", margin=self.margin)
        if self.max_image_motion is not None and self.max_image_motion_px is not None:
            raise ConfigurationError(
                "predictive: give max_image_motion (normalized units) or max_image_motion_px "
                f"(pixels), not both (got {self.max_image_motion!r} and "
                f"{self.max_image_motion_px!r})"
            )
        self._camera = Camera()
        self._gate_px: float | None = None
        self._camera_rate: float | None = None
        """The bound camera's frame rate (Hz, :meth:`bind_tracker`; None: every period)."""
        self.loop_budget: float | None = None
        """The servo loop's budget when ``time_budget`` is None (:meth:`bind_period`, s)."""
        self._seen = SeenJoints(self.latency)
        self._gain = MotionGain()
        self._U: FloatArray | None = None
        self._goal: FloatArray | None = None
        self._prior: FloatArray | None = None
        """The goal when the running search started (the one its result is judged against)."""
        self._search = GoalSearch(GOAL_RANDOM_SEEDS)
        self._memo = SeedMemo()
        """The goal search's seeds across the run's searches (among static obstacles)."""
        self.replans = Replan(self.replan)
        """When the goal search starts (:mod:`~redservo.redundancy.predictive_replan`)."""
        self._calls = 0
        self.clock: Callable[[], float] = time.perf_counter
        """The clock of ``time_budget`` (s, monotonic): a test sets a fake one."""
        self._obs: Callable[[FloatArray, FloatArray | None], Model | None] | None = None
        self._parts = GoalModel(self.model_depth)
        """What the global models are built with (:func:`~redservo.redundancy.goal_model.
        observation`, shared with ``qp-goal``): the depths, camera, poses, last moment model."""
        self._parts.camera = self._camera
        self._pose = self._parts.pose
        self.dot_poses = self._parts.dot_poses
        """The moment model's target pose by PnP of the tracked dots (:meth:`observe_dots`)."""
        self._dt = 0.0
        self.last_start: FloatArray | None = None
        """The linearisation point ``Ū`` (Nc, n) of the last solve (the warm start)."""
        self.last_plan: FloatArray | None = None
        """The last solution ``U`` (Nc, n), None after a fallback."""
        self.last_model: Model | None = None
        """The global model of the last solve (None: the local model)."""

    def _inner_laws(self) -> tuple[Law, ...]:
        """The fallback law: :meth:`Law.set_safety` sets its safety options too."""
        return (self._fallback,)

    def reset(self) -> None:
        """Forget the warm start and the observation."""
        self._U = None
        self._obs = None
        self._goal = self._prior = None
        self._search.reset()
        self._memo.reset()
        self.replans.reset()
        self._seen.reset()
        self._gain.reset()
        self._parts.reset()
        self._calls = 0
        self.last_start = self.last_plan = None

    def warm_up(self, limits: JointLimits, m: int, dt: float) -> None:
        """Pay a first call's one-time costs outside any time budget, then :meth:`reset`
        (:func:`~redservo.redundancy.predictive_budget.warm_up`); a servo loop calls it
        before its first period."""
        warm_up(self, limits, m, dt)
        self.reset()

    def bind_camera(self, camera: Camera) -> None:
        """Use ``camera``'s image for the visibility constraints (default :class:`Camera`)."""
        self._camera = self._parts.camera = camera

    def bind_period(self, period: float, clock: Callable[[], float]) -> None:
        """A servo loop's period (s) and clock (s, monotonic): without a ``time_budget``, a
        step's budget is :data:`~redservo.redundancy.predictive_budget.LOOP_SHARE` of the
        period, on ``clock``; a step past it returns the fallback, flagged."""
        self.loop_budget = LOOP_SHARE * float(period)
        self.clock = clock

    def bind_tracker(self, gate_px: float | None, frame_rate: float | None = None) -> None:
        """The gate (pixels) of the tracker that measures the features (None: no tracker,
        the ideal sensor): the default camera-motion limit is a fraction of it per frame
        (:class:`~redservo.redundancy.predictive_camera.MotionLimit`); ``frame_rate`` (Hz,
        None: a frame every period) the camera's, used when the ``frame_rate`` option is
        None."""
        self._gate_px = gate_px
        self._camera_rate = frame_rate

    def motion_limit(self, dt: float) -> MotionLimit | None:
        """The camera-motion limit per period ``dt`` (s) from the options and the bound
        camera and tracker (None: none)."""
        return MotionLimit.resolve(
            normalized=self.max_image_motion,
            pixels=self.max_image_motion_px,
            gate_px=self._gate_px,
            frame_rate=self.frame_rate if self.frame_rate is not None else self._camera_rate,
            dt=dt,
            camera=self._camera,
        )

    def observe_dots(self, dots: FloatArray, age: float) -> None:
        """A loop's hook with the frame in use: its tracked dots (N, 2; normalized) exposed
        ``age`` seconds ago. The moment model then takes the target's pose from them by PnP
        (:mod:`redservo.redundancy.predictive_pnp`)."""
        self.dot_poses.frame(dots, age)

    def observe(self, robot: Any, task: Any, state: Any) -> None:
        """The :class:`~redservo.Controller`'s hook before each call: the model robot, the
        task and its evaluated state (``s``, ``inv_depth``). For a task of image points of
        one target, or of the moment features of one target, it sets the global model for
        the next call (only)."""
        self._obs = None
        if self.model != "global":
            return
        obs = observation(self._parts, robot, task, state)
        if obs is not None:  # the period of the step is known when it is built
            self._obs = lambda q, seen: obs(q, seen, self._dt)

    # -- one step ------------------------------------------------------------------------------

    def compute(self, x: LawInputs) -> LawResult:
        budget = self.time_budget if self.time_budget is not None else self.loop_budget
        dl = Deadline(budget, self.clock)  # covers the model, the goal and the solve
        # With a budget, the fallback first: a step whose deadline passes returns it at once.
        safe = None if dl.budget is None else self._fallback.compute(x)
        obs, self._obs = self._obs, None
        hz = self._hz
        start = self.last_start = self._start(x, x.q.shape[0])
        seen = self._seen.push(x.q, x.dt)
        self._dt = x.dt
        model = None if obs is None or dl.passed() else obs(x.q, seen)
        if model is not None and self.goal_weight > 0 and not dl.passed():
            self._update_goal(model, x, dl)
        self._calls += 1
        self.last_model = model
        lim = None if model is None else self.motion_limit(x.dt)
        if lim is not None and model is not None:
            lim = self._gain.update(model, x.q, x.qdot_prev, x.dt, lim)
        U, why, value, iters = start, 0, 0.0, 0
        for _ in range(self.sqp_iterations):
            if dl.passed():
                break
            with np.errstate(all="ignore"):
                qp = horizon_qp(self, x, U, model, lim)
            if qp is None or not all(np.all(np.isfinite(a)) for a in (qp.H, qp.f, qp.A)):
                why, value = fb.HORIZON_INFEASIBLE, float("nan")
                break
            U, why, value, iters = self._solve(qp, U)
            if why:
                break
        elapsed = dl.elapsed()
        by_budget = not why and dl.passed()
        if by_budget:
            why, value = fb.SOLVER_ITERATIONS, elapsed
        if why:
            res = self._fall_back(x, why, value, by_budget, safe)
            return self.dot_poses.flagged(limited(res, x, model, lim))
        self._U = U
        self.last_plan = U.copy()
        what = "global" if model is not None else "local"
        info: tuple[str, ...] = (
            f"predictive: {what} model, N = {hz.N}, Nc = {hz.Nc}, daqp {iters} iteration(s)",
        )
        rank = int(np.linalg.matrix_rank(x.J1, tol=self.rcond * float(np.max(np.abs(x.J1)))))
        d = Diagnostics(
            method=self.name, task_rank=rank, rank_deficient=rank < x.J1.shape[0], info=info
        )
        res = limited(LawResult(np.ascontiguousarray(U[0]), d), x, model, lim)
        return self.dot_poses.flagged(res)

    def _start(self, x: LawInputs, n: int) -> FloatArray:
        """The warm start ``Ū``: the previous solution shifted by one period (its last block
        repeated), else ``q̇_prev`` (or 0) in every block."""
        Nc = self._hz.Nc
        if self._U is not None and self._U.shape == (Nc, n):
            return np.vstack([self._U[1:], self._U[-1:]])
        prev = np.zeros(n) if x.qdot_prev is None else x.qdot_prev
        return np.tile(prev, (Nc, 1))

    def _band(self, x: LawInputs) -> FloatArray:
        lim = x.limits
        return np.maximum(self.margin * (lim.q_max - lim.q_min), lim.margin_abs)

    def _update_goal(self, model: Model, x: LawInputs, dl: Deadline) -> None:
        """Start the joint-goal search (docs/predictive.md, "Joint goal";
        :class:`~redservo.redundancy.predictive_goal.GoalSearch`, within the limits less the
        band) at the first period, then ``replan`` periods after the previous start once that
        one is over, and advance it by ``goal_steps`` iterations a period (and, with a
        ``time_budget``, until half of it has passed since the step began, ``dl``): no single
        step pays for the whole search, its state goes on in the next periods. The previous
        goal is kept when it is still the better one. Avoiding collisions among static
        obstacles, a new search takes from the memo what the seeds independent of ``q`` gave
        before, and a futile search defers the next (:mod:`~redservo.redundancy.
        predictive_replan`)."""
        band = self._band(x)
        lo, hi = x.limits.q_min + band, x.limits.q_max - band
        span, key = x.limits.q_max - x.limits.q_min, model_key(model)
        if not self._search.running and self.replans.due(self._calls, x.q, span, key):
            memo = self._memo if static_scene(self) else None
            self._search.start(model, x.q, lo, hi, span, goal_clearance(self), memo)
            self.replans.start(self._calls, x.q, key, self._goal)
            self._prior = self._goal
        if not self._search.running:
            return
        try:
            with np.errstate(all="ignore"):
                done, found = self._search.advance(dl.at(0.5), dl.clock, self.goal_steps)
                found = found if done else self._search.early(x.q)
        except np.linalg.LinAlgError:  # a degenerate start: the goal as it was
            self._search.reset()
            return
        if done or found is not None:
            self._goal = better_goal(model, self._prior, found)
        if done:
            self.replans.end(self._calls, x.q, span, key, self._goal, static_scene(self))

    def _solve(self, qp: QP, start: FloatArray) -> tuple[FloatArray, int, float, int]:
        """``(U, why, value, iterations)``: :func:`~redservo.redundancy.predictive_qp.
        solve_horizon` with this law's iteration limit."""
        return solve_horizon(qp, start, self.max_qp_iterations)

    def _fall_back(
        self, x: LawInputs, why: int, value: float, by_budget: bool, safe: LawResult | None
    ) -> LawResult:
        """The ``qp`` law's command (``safe`` when already computed), with the flag that
        caused it and ``solver-fallback``."""
        self._U = None
        self.last_plan = None
        res = self._fallback.compute(x) if safe is None else safe
        return fallback_result(
            res, why, value, by_budget=by_budget, name=self.name, horizon=self._hz.N
        )
