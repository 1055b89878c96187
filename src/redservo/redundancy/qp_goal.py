"""``qp-goal``: the bounded least squares of ``qp`` steered by a joint-space goal.

A reactive law (one step from the current state, no horizon, no prediction of the motion)::

    q̇ = argmin ‖J1 q̇ + λ e_eff‖² + ε ‖q̇ - q̇_2‖²   s.t. the joint-velocity bounds of ``qp``
    q̇_2 = -k (q - q*)                               (the goal term, CM01 eq. 11's form)

``q*`` (rad or m) is a configuration within the limits less the band ``margin`` whose
features equal ``s*``: the joint goal of the ``predictive`` law
(:mod:`redservo.redundancy.predictive_goal`, the same search, imported), found from the
model of the current observation (:mod:`redservo.redundancy.goal_model`). The goal term
acts in the directions the task and the bounds leave free (the ε-level of ``qp``, i.e. the
projection in ``Ker J1`` when no bound is active) and vanishes at ``q = q*``.

**Switching rule** (``switch = True``). ``qp`` fails on a third of the reachable samples of
the safety campaigns by stalling at a KKT point under the joint bounds, and the goal then
lies in another region of the joint space (docs/results.md, "Why the reactive laws stop
near 70 %"). There ``‖e1‖`` levels off at the part of the error the bounds hold:
``qp``'s relative residual ``r`` (its ``task-scaled`` value) times ``‖e1‖``. A slow decay is
no stall: where the bounds slow ``qp`` down and it still converges, that level is below the
tolerance. The task has stalled (:meth:`QpGoal._stalled`) when, over the last ``stall``
periods, ``‖e1‖`` decayed at less than :data:`PROGRESS` of its nominal rate λ, or at less
than :data:`SLOWED` of it while ``r`` stayed at :data:`HELD` or more for
:data:`HELD_PERIODS` periods with the level ``r ‖e1‖`` above ``tolerance``. With the
default ``gain`` 0 the law is ``qp`` until a stall, and the rule can be checked on ``qp``'s
own runs: on both safety campaigns (N = 200, seed 0, ideal sensor) it fires on every ``qp``
run at the iteration cap (medians: period 177 on panda-near-limits, 127 on
mc05-joint-limits) and on one ``qp`` run that converges (mc05 sample 24, whose decay fell to
31 % of λ with ``r`` at 0.83 before a bound let go). When it has stalled
and a goal is known farther than ``arrive`` of some joint's range, the task is relaxed and the
command is the joint-space move ``q̇ = -k_g (q - q*)`` (``goal_gain`` k_g, 1/s): a straight
line in joint space between two configurations within the bounds, so it stays within them.
It ends when every joint is within ``arrive`` of its range from ``q*``; the task law then
resumes near a configuration where the error is zero. Each step of the move is flagged
``task-scaled`` with the value 0 (the task is not executed) and says so in its message.

The goal is searched from the first period on (spread over periods: ``goal_steps``
iterations per period, as the ``predictive`` law does), and again at each stall; a new
search keeps the previous goal when that one is still as good (``better_goal``). Without a
model (a bare law call, a task of lines) there is no goal and the law is ``qp`` exactly.

State kept between calls (``stateful``): the goal and its search, the stall counter, the
mode, the model's target pose; :meth:`reset` clears them. Units: rad or m, rad/s or m/s, s.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.camera import Camera
from redservo.redundancy.base import (
    RCOND,
    Diagnostics,
    Law,
    LawInputs,
    LawResult,
    register,
)
from redservo.redundancy.flags import Event, Flag
from redservo.redundancy.goal_model import GoalModel, Model
from redservo.redundancy.goal_move import (
    RETURN,
    centroid_rows,
    image_rows,
    kept_in_image,
    pair_rows,
    solve_move,
)
from redservo.redundancy.options import Option
from redservo.redundancy.predictive_goal import GoalSearch, goal_error
from redservo.redundancy.qp import qp_velocity_bounds
from redservo.redundancy.safety import command_box

__all__ = ["GOAL_RANDOM_SEEDS", "QpGoal", "goal_term"]

GOAL_RANDOM_SEEDS = 60
"""Seeds drawn uniformly within the bounds after the seven near ``q`` (the ``predictive``
law's number)."""
HOLDS = 1e-4
"""A goal whose error ``‖e(q*)‖`` under the current model is below this still holds (task
units)."""
MOVE_SPEED = 0.5
"""Fraction of the velocity limits the joint move uses at most."""
MOVE_WEIGHT = 1e-3
"""Relative weight ``w`` of the goal term in the joint move (:mod:`redservo.redundancy.goal_move`)."""
PROGRESS = 0.25
"""The task stalls when ``‖e1‖`` decays at less than this fraction of its nominal rate λ over
the last ``stall`` periods, ..."""
SLOWED = 0.5
"""... or at less than this fraction while the bounds hold it at a level above the tolerance."""
HELD = 0.5
"""``qp``'s relative task residual from which the bounds hold the task."""
HELD_PERIODS = 10
"""Periods in a row with ``qp``'s relative residual at :data:`HELD` or more before its level
``r ‖e1‖`` is trusted."""


def kept_goal(
    model: Model, old: FloatArray | None, new: tuple[float, FloatArray] | None
) -> FloatArray | None:
    """The goal after a search: the previous goal ``old`` while its error under the current
    model is below :data:`HOLDS` or no worse than the new one's (a goal that changes in the
    middle of a joint move turns it around), else the search's result ``new``
    (``(error, q*)`` or None)."""
    if new is None:
        return old
    if old is None:
        return new[1]
    r_old = goal_error(model, old)
    return old if r_old <= max(HOLDS, new[0]) else new[1]


def move_bounds(x: LawInputs, margin: float, shield: bool) -> tuple[FloatArray, FloatArray]:
    """The joint move's velocity box (rad/s or m/s): ``qp``'s bounds with the goal's band
    ``margin`` and :data:`MOVE_SPEED` of the velocity limits (a move at full speed cannot
    brake within the acceleration limits before a point reaches the image border), within
    the safety box of every law (velocity, acceleration, position and braking,
    :func:`~redservo.redundancy.safety.command_box`), which wins where they miss."""
    lim = x.limits
    lo, hi = command_box(x.q, lim, x.dt, x.qdot_prev, shield=shield)
    v = None if lim.qdot_max is None else MOVE_SPEED * lim.qdot_max
    blo, bhi, _ = qp_velocity_bounds(x.q, lim, x.dt, margin=margin, v_max=v)
    lo2, hi2 = np.maximum(lo, blo), np.minimum(hi, bhi)
    ok = lo2 <= hi2
    return np.where(ok, lo2, lo), np.where(ok, hi2, hi)


def goal_term(q: FloatArray, goal: FloatArray, gain: float) -> FloatArray:
    """``-gain (q - goal)`` (n,), rad/s or m/s: the gradient step of ``gain ‖q - goal‖² / 2``
    (``gain`` in 1/s); zero at ``q = goal``."""
    return np.asarray(-gain * (q - goal))


def _stack(
    a: tuple[FloatArray, FloatArray, FloatArray], b: tuple[FloatArray, FloatArray, FloatArray]
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The rows ``(G, bl, bu)`` of the move, ``a``'s above ``b``'s."""
    G, bl, bu = (np.ascontiguousarray(np.concatenate([x, y])) for x, y in zip(a, b, strict=True))
    return G, bl, bu


@register
class QpGoal(Law):
    """``qp`` with a joint-space goal in its secondary level, and a joint move to the goal at a
    stall (module docstring)."""

    name = "qp-goal"
    description = (
        "qp; when the joint bounds stall the task, a joint move to a goal q* whose features "
        "are s* (the predictive law's goal search), the target kept in the image"
    )
    stateful = True

    OPTIONS = (
        Option(
            "gain",
            0.0,
            doc="gain k of the goal term -k (q - q*) in qp's secondary level (0: qp until a stall)",
            unit="1/s",
            low=0.0,
        ),
        Option(
            "goal_gain",
            2.0,
            doc="gain k_g of the joint move to q* at a stall",
            unit="1/s",
            low=0.0,
            low_open=True,
        ),
        Option("switch", True, kind="bool", doc="move to q* with the task relaxed at a stall"),
        Option(
            "stall",
            25,
            kind="int",
            doc="window (periods) over which a decay of ‖e1‖ below 25 % of λ (50 % when held) is a stall",
            low=1,
        ),
        Option(
            "arrive",
            0.0005,
            doc="the joint move ends when every joint is this close to q*, a fraction of its range",
            low=0.0,
            high=0.5,
            low_open=True,
        ),
        Option(
            "margin",
            0.0102,
            doc="the goal lies this far inside each joint limit, a fraction of the range",
            low=0.0,
            high=0.5,
            high_open=True,
        ),
        Option(
            "tolerance",
            0.001,
            doc="the error ‖e1‖ the run converges at: qp held above it is a stall",
            unit="task units",
            low=0.0,
            low_open=True,
        ),
        Option(
            "goal_steps",
            60,
            kind="int",
            doc="iterations of the goal search per period (each one kinematics evaluation)",
            low=1,
        ),
        RCOND,
    )
    gain: float
    goal_gain: float
    switch: bool
    stall: int
    arrive: float
    margin: float
    tolerance: float
    goal_steps: int

    def _setup(self) -> None:
        from redservo.redundancy.base import make_law

        self._qp = make_law("qp", rcond=self.rcond)
        self._model = GoalModel()
        self._search = GoalSearch(GOAL_RANDOM_SEEDS)
        self.reset()

    def _inner_laws(self) -> tuple[Law, ...]:
        """The inner ``qp`` law: :meth:`Law.set_safety` sets its safety options too."""
        return (self._qp,)

    def reset(self) -> None:
        """Forget the goal, its search, the stall counter, the mode and the model."""
        self.goal: FloatArray | None = None
        """The joint goal ``q*`` (n,), rad or m, or None (not found yet)."""
        self.moving = False
        """The law is moving to the goal with the task relaxed."""
        self.switches = 0
        """Joint moves started in this run."""
        self._search.reset()
        self._model.reset()
        self._sizes: list[float] = []
        self._held = 0
        self._level = 0.0
        self._started = False

    # -- the hooks of the Controller and the simulation loop -------------------------------------

    def observe(self, robot: Any, task: Any, state: Any) -> None:
        """The Controller's hook before each call (:mod:`redservo.redundancy.goal_model`)."""
        self._model.observe(robot, task, state)

    def bind_camera(self, camera: Camera) -> None:
        """The simulation's camera (the PnP of the tracked dots of a moment task)."""
        self._model.camera = camera

    def observe_dots(self, dots: FloatArray, age: float) -> None:
        """The tracked dots of the frame in use (a moment task's target pose by PnP)."""
        self._model.dot_poses.frame(dots, age)

    # -- one step ------------------------------------------------------------------------------

    def compute(self, x: LawInputs) -> LawResult:
        model = self._model.build(x.q, x.dt)
        stalled = self._stalled(float(np.linalg.norm(x.e1)), x.lam, x.dt)
        if model is not None:
            self._advance(model, x, stalled)
        if self.moving and self._arrived(x):
            self.moving = False
            self._sizes.clear()
            self._held = 0
        elif stalled and self.switch and self.goal is not None and not self._arrived(x):
            if not self.moving:
                self.switches += 1
            self.moving = True
        if self.moving and self.goal is not None:
            return self._move(x, self.goal, model)
        return self._task(x)

    def _task(self, x: LawInputs) -> LawResult:
        """``qp`` with the goal term added to the secondary level (module docstring)."""
        sec = x.secondary
        if self.goal is not None and self.gain > 0.0:
            term = goal_term(x.q, self.goal, self.gain)
            sec = term if sec is None else sec + term
        res = self._qp.compute(x._replace(secondary=sec))
        resid = res.diagnostics.value(Flag.TASK_SCALED)
        held = resid is not None and resid >= HELD
        self._held = self._held + 1 if held else 0
        self._level = resid * float(np.linalg.norm(x.e1)) if resid is not None and held else 0.0
        return LawResult(res.qdot, replace(res.diagnostics, method=self.name))

    def _stalled(self, size: float, lam: float, dt: float) -> bool:
        """True when ``‖e1‖`` (``size``) fell by less than :data:`PROGRESS` of the nominal
        decay ``exp(-λ K dt)`` over the last ``K = stall`` periods, or by less than
        :data:`SLOWED` of it while the bounds held the task for :data:`HELD_PERIODS` periods
        at a level ``r ‖e1‖`` above ``tolerance`` (module docstring: a slow decay toward a
        level below the tolerance is no stall)."""
        hist = self._sizes
        hist.append(size)
        if len(hist) <= self.stall:
            return False
        old = hist.pop(0)
        if size > old * float(np.exp(-PROGRESS * lam * self.stall * dt)):
            return True
        held = self._held >= HELD_PERIODS and self._level > self.tolerance
        return held and size > old * float(np.exp(-SLOWED * lam * self.stall * dt))

    def _arrived(self, x: LawInputs) -> bool:
        """Every joint is within ``arrive`` of its range from the goal (True: no goal)."""
        if self.goal is None:
            return True
        span = x.limits.q_max - x.limits.q_min
        return bool(np.all(np.abs(x.q - self.goal) <= self.arrive * span))

    def _advance(self, model: Model, x: LawInputs, stalled: bool) -> None:
        """Start the goal search at the first period and at a stall, and run ``goal_steps`` of
        its iterations (module docstring)."""
        lim = x.limits
        span = lim.q_max - lim.q_min
        band = np.maximum(self.margin * span, lim.margin_abs)
        lo, hi = lim.q_min + band, lim.q_max - band
        due = not self._started or (stalled and not self.moving)
        if due and not self._search.running:
            self._search.start(model, x.q, lo, hi, span)
            self._started = True
        if not self._search.running:
            return
        try:
            with np.errstate(all="ignore"):
                done, found = self._search.advance(None, steps=self.goal_steps)
        except np.linalg.LinAlgError:  # a degenerate start: the goal as it was
            self._search.reset()
            return
        if done:
            self.goal = kept_goal(model, self.goal, found)

    def _move(self, x: LawInputs, goal: FloatArray, model: Model | None) -> LawResult:
        """The joint move to ``goal`` with the task relaxed, flagged ``task-scaled`` (0):
        :mod:`redservo.redundancy.goal_move` (the goal term under the image's centroid and
        border rows, within ``qp``'s bounds); without the model's image points, the goal term
        within the bounds."""
        term = goal_term(x.q, goal, self.goal_gain)
        lim = x.limits
        lo, hi = move_bounds(x, self.margin, self.shield)
        rows = None if model is None else centroid_rows(model, x.q, goal)
        qdot = None
        if rows is not None:
            for back in (RETURN, 0.0):  # a point past the border line: return, else stay
                cam = self._model.camera
                damper = _stack(image_rows(rows, cam, x.dt, back), pair_rows(rows, cam, x.dt, back))
                qdot = solve_move(rows, x.lam, term, (lo, hi), damper, MOVE_WEIGHT)
                if qdot is not None:
                    qdot = kept_in_image(model, x.q, qdot, x.dt, self._model.camera, rows.s)
                    break
        if qdot is None:  # no move keeps the target in the image: the task law this period
            return self._task(x)
        far = float(np.max(np.abs(x.q - goal) / (lim.q_max - lim.q_min)))
        msg = (
            f"qp-goal: the task stalled; joint move to the goal q* with the task relaxed "
            f"(largest joint distance {far:.3g} of its range)"
        )
        d = Diagnostics(
            method=self.name,
            task_rank=int(np.linalg.matrix_rank(x.J1)),
            overconstrained=True,
            events=(Event(Flag.TASK_SCALED, 0.0, msg),),
            info=(f"qp-goal: joint move {self.switches}",),
        )
        return LawResult(np.ascontiguousarray(qdot), d)
