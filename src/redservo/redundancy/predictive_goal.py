"""The ``predictive`` law's joint goal ``q*``: a configuration within the limits less the band
whose predicted task error is zero (docs/predictive.md, "Joint goal").

The search has two stages, because the image error alone is a poor guide far from the goal
(a random seed often puts the target behind the camera, where the projection is undefined):

1. **The desired camera pose** ``bMc*`` from the image: virtual visual servoing of the
   target's points (in the base frame, :class:`~redservo.redundancy.predictive_model.PointModel`)
   from the current camera pose, Gauss-Newton steps ``v_c = −L⁺ (s − s*)`` (CM01 eq. 26 for
   ``L``) applied as ``bMc ← bMc exp(v_c)`` until ``‖s − s*‖ < 1e-10``; for the moment
   features, ``bMo cMo*⁻¹`` (:mod:`redservo.redundancy.predictive_moments`).
2. **Inverse kinematics of that pose** (:func:`redservo.robots.ik.solve_ik`, the campaigns'
   reachability search) from each seed in turn, then a few steps of feature-space projected
   damped least squares on ``e(q) = C (s(q) − s*)`` to bring the predicted error below
   :data:`TOL`. Of the first :data:`CANDIDATES` seeds that get there, the goal nearest to
   ``q`` is ``q*``.

When stage 1 fails (a point behind the camera, no convergence), the feature-space search
runs from the seeds directly; when no seed reaches a zero error, the best configuration met
may be the goal (:func:`joint_goal`). Units: metres, radians, normalized image coordinates.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Generator
from typing import cast

import numpy as np

from redservo._validation import FloatArray
from redservo.redundancy.predictive_model import PointModel, horizon
from redservo.redundancy.predictive_model import _points_interaction as points_interaction
from redservo.redundancy.predictive_moments import MomentModel
from redservo.redundancy.predictive_replan import SeedMemo, model_key
from redservo.redundancy.predictive_stages import (
    CANDIDATES,
    STALL,
    TOL,
    Best,
    Clear,
    Met,
    _anywhere,
    _feature_stage,
    _pose_stage,
)

__all__ = [
    "CANDIDATES",
    "STALL",
    "TOL",
    "GoalSearch",
    "better_goal",
    "camera_goal",
    "goal_error",
    "joint_goal",
    "nearest_goal",
    "search_steps",
]


def camera_goal(model: PointModel, bMc: FloatArray, iterations: int = 50) -> FloatArray | None:
    """``bMc*`` (4, 4): the camera pose at which the model's points project at ``s*``
    (virtual visual servoing from ``bMc``), or None (a point at or behind the camera,
    or no convergence)."""
    from redservo.spatial import exp_twist  # scipy: not loaded by ``import redservo``

    T = np.array(bMc, dtype=float)
    for _ in range(iterations):
        Pc = (model.P_b - T[:3, 3]) @ T[:3, :3]
        if not np.all(Pc[:, 2] > 1e-6):
            return None
        iz = 1.0 / Pc[:, 2]
        xy = Pc[:, :2] * iz[:, None]
        e = xy.reshape(-1) - model.s_star
        if not np.all(np.isfinite(e)):
            return None
        if float(np.linalg.norm(e)) < 1e-10:
            return T
        v = -np.linalg.lstsq(points_interaction(xy, iz), e, rcond=None)[0]
        T = T @ exp_twist(v)
    return None


def better_goal(
    model: PointModel | MomentModel,
    old: FloatArray | None,
    new: tuple[float, FloatArray] | None,
) -> FloatArray | None:
    """The better of the previous goal ``old`` (its error under the current model) and the
    result ``new`` of a search (:func:`joint_goal`): a failed search keeps a goal that still
    holds, a best-effort goal gives way to an exact one."""
    if old is None:
        return None if new is None else new[1]
    r_old = goal_error(model, old)
    if new is None or r_old <= new[0]:
        return old if r_old < np.inf else None
    return new[1]


class GoalSearch:
    """A joint-goal search that can be spread over several periods (a servo loop's time
    budget): :meth:`start` draws the seeds, :meth:`advance` runs seeds until a deadline and
    returns the goal once the search is over (:func:`search_steps`); :meth:`early` gives the
    exact goal met so far nearest the current configuration while it runs."""

    def __init__(self, random_seeds: int) -> None:
        self.random_seeds = random_seeds
        self.iterations = 0
        """The iterations run by the last :meth:`advance`."""
        self._steps: Generator[None, None, tuple[float, FloatArray] | None] | None = None
        self._met = Met()
        self._early: Callable[[FloatArray | None], tuple[float, FloatArray] | None] | None = None

    @property
    def running(self) -> bool:
        """A search is under way."""
        return self._steps is not None

    def reset(self) -> None:
        """Drop a search under way."""
        self._steps = None
        self._met, self._early = Met(), None

    def early(self, q: FloatArray | None = None) -> tuple[float, FloatArray] | None:
        """``(‖e(q*)‖, q*)`` under the search's model: of the exact goals both stages have
        met so far, the one nearest ``q`` (rad or m, the current configuration; None: the
        search's start) in fractions of each range, one whose straight joint path from the
        search's start is clear of the obstacles first (as :func:`nearest_goal`), or None
        (none yet, none with a clear path, or no search running). Called each period with the current configuration, a nearer goal met
        later replaces a far one met first (panda-near-limits sample 66: the first goal met
        was 0.84 of a joint's range away, and steering to it, then to the next, stalled the
        run). The result at the end of the search is :meth:`advance`'s."""
        if self._steps is None or self._early is None:
            return None
        return self._early(q)

    def start(
        self,
        model: PointModel | MomentModel,
        q: FloatArray,
        lo: FloatArray,
        hi: FloatArray,
        span: FloatArray,
        clear: Clear | None = None,
        memo: SeedMemo | None = None,
    ) -> None:
        """Seeds: ``q``, six around it (normal, 15 % of each joint's range ``span``) and
        :attr:`random_seeds` uniform within ``[lo, hi]``, a generator seeded with 0;
        ``clear`` and ``memo`` as :func:`search_steps`'s."""
        gen = np.random.default_rng(0)
        seeds = [q] + [q + gen.normal(0.0, 0.15, q.shape) * span for _ in range(6)]
        seeds += [gen.uniform(lo, hi) for _ in range(self.random_seeds)]
        met = Met()
        self._steps = search_steps(model, q, seeds, lo, hi, clear, met, memo)
        ok = _anywhere if clear is None else clear
        self._met = met

        clear_from_start: dict[int, bool] = {}  # by id of a goal met (kept alive in met)

        def early(now: FloatArray | None) -> tuple[float, FloatArray] | None:
            found = list(zip(met.pose_error, met.pose, strict=True))
            found += [] if met.feature is None else [met.feature]
            if not found:
                return None
            at = q if now is None else now
            # Among obstacles, only a goal with a clear straight path (_clear_path, from the
            # start, once a goal): the plan pulled towards one behind a ball stays held at
            # d_safe (panda-posts sample 80). The errors are those recorded when the goals
            # were met: no prediction, no collision probe a period.
            for _, g in found:
                if id(g) not in clear_from_start:
                    clear_from_start[id(g)] = _clear_path(ok, q, g)
            goal = min(
                found, key=lambda f: (not clear_from_start[id(f[1])], _spread(f[1], at, lo, hi))
            )
            return goal if clear_from_start[id(goal[1])] else None

        self._early = early

    def advance(
        self,
        deadline: float | None,
        clock: Callable[[], float] = time.perf_counter,
        steps: int | None = None,
    ) -> tuple[bool, tuple[float, FloatArray] | None]:
        """``(done, result)``: run the search until it ends, ``steps`` iterations have run
        (None: no limit; one iteration is one kinematics evaluation and one damped
        least-squares step, tens of microseconds) or ``clock()`` (s) passes ``deadline``
        (None: none); one iteration at least per call. The search's state (the seed under
        way, its iterate, the goals found so far) is kept for the next call."""
        if self._steps is None:
            return True, None
        self.iterations = 0
        try:
            while True:
                next(self._steps)
                self.iterations += 1
                if steps is not None and self.iterations >= steps:
                    return False, None
                if deadline is not None and clock() > deadline:
                    return False, None
        except StopIteration as stop:  # the last iteration, which ends it without a yield
            self.iterations += 1
            self.reset()
            return True, stop.value


def goal_error(model: PointModel | MomentModel, q: FloatArray) -> float:
    """``‖e(q)‖`` under the model (``inf`` when the prediction fails)."""
    pred = model.predict(q, np.zeros((1, q.shape[0])), horizon(1, 1), 0.0)
    return np.inf if pred is None else float(np.linalg.norm(pred.e[0]))


def joint_goal(
    model: PointModel | MomentModel,
    q: FloatArray,
    seeds: list[FloatArray],
    lo: FloatArray,
    hi: FloatArray,
) -> tuple[float, FloatArray] | None:
    """``(‖e(q*)‖, q*)`` with ``q*`` within ``[lo, hi]`` (module docstring), or None when no
    seed reaches it: :func:`search_steps` run to its end."""
    steps = search_steps(model, q, seeds, lo, hi)
    try:
        while True:
            next(steps)
    except StopIteration as stop:
        return cast("tuple[float, FloatArray] | None", stop.value)


def search_steps(
    model: PointModel | MomentModel,
    q: FloatArray,
    seeds: list[FloatArray],
    lo: FloatArray,
    hi: FloatArray,
    clear: Clear | None = None,
    met: Met | None = None,
    memo: SeedMemo | None = None,
) -> Generator[None, None, tuple[float, FloatArray] | None]:
    """The search of :func:`joint_goal`, yielding after each iteration of its inverse
    kinematics (one kinematics evaluation and one step: so that it can be spread over periods
    in equal small parts); its return value is the result. With ``clear`` (collision
    avoidance on: :func:`~redservo.redundancy.predictive_distance.goal_clearance`), a
    configuration that is not clear of the obstacles is never the goal. ``met`` (the
    caller's): the exact goals are recorded in it as they are met, so that a search spread
    over periods gives the nearest so far before it ends (:meth:`GoalSearch.early`). ``memo``
    (collision avoidance among static obstacles: :mod:`redservo.redundancy.predictive_replan`):
    what the seeds that do not depend on ``q`` gave in the run's earlier searches with the
    same model, desired camera pose and bounds is taken from it, without their iterations.

    Two stages (module docstring): the pose IK of the desired camera pose from each seed,
    whose result is the nearest of the first :data:`CANDIDATES` exact goals, and the
    feature-space search from each seed in turn, whose result is its first exact goal (the
    task may be met at other poses than ``bMc*``, e.g. the moment features). The result is
    the pose stage's if it met any exact goal, else the feature stage's; when no seed reaches
    a zero error, the best configuration met is the goal if its error is below a tenth of the
    error at ``q`` (the goal lies just beyond the band: the law gets as close as the band
    allows). The two stages run in turn, :data:`POSE_SHARE` iterations of the pose stage for
    one of the feature stage, so that a goal only the feature stage finds (mc05's desired camera pose is often beyond the bounds: its pose IK fails
    from every seed, about 3 000 iterations) is met in the first periods; the result is the
    one of the two stages run one after the other.
    """
    bMc = model.robot.kinematics(q, check_limits=False)[0]
    target = model.camera_goal(bMc) if isinstance(model, MomentModel) else camera_goal(model, bMc)
    ok: Clear = _anywhere if clear is None else clear
    met = Met() if met is None else met
    if memo is not None:  # the seeds' results hold for this model, camera goal and bounds
        goal = np.zeros(16) if target is None else np.ravel(target)
        memo.bind(np.concatenate([model_key(model), [target is None], goal, lo, hi]))
    stages = {"feature": _feature_stage(model, seeds, lo, hi, ok, met, memo)}
    if target is not None:
        stages = {"pose": _pose_stage(model, target, seeds, lo, hi, ok, met, memo), **stages}
    bests = yield from _in_turn(
        stages, {"pose": POSE_SHARE, "feature": 1}, lambda ended: "pose" in ended and bool(met.pose)
    )
    if met.pose:
        return nearest_goal(model, met.pose, q, lo, hi, ok)
    if met.feature is not None:
        return met.feature
    best = min(bests, key=lambda b: b[0])  # the pose stage's first: it wins a tie
    if best[1] is not None and best[0] < 0.1 * goal_error(model, q):
        return best[0], best[1]
    return None


def _in_turn(
    stages: dict[str, Generator[None, None, Best]],
    shares: dict[str, int],
    stop: Callable[[set[str]], bool],
) -> Generator[None, None, list[Best]]:
    """Run ``stages`` in turn, ``shares[name]`` iterations each a turn (one ``yield`` an
    iteration), until every one has ended or ``stop`` (the names of those ended) holds;
    returns their values in their order (a stage cut short: ``(inf, None)``)."""
    ended: dict[str, Best] = {}
    running = dict(stages)
    while running:
        for name, steps in list(running.items()):
            try:
                for _ in range(shares[name]):
                    next(steps)
                    yield
            except StopIteration as end:
                ended[name] = end.value
                del running[name]
                if stop(set(ended)):
                    return [ended.get(n, (np.inf, None)) for n in stages]
    return [ended[n] for n in stages]


def nearest_goal(
    model: PointModel | MomentModel,
    found: list[FloatArray],
    q: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    ok: Clear = _anywhere,
) -> tuple[float, FloatArray]:
    """``(‖e(q*)‖, q*)``: of the exact goals ``found`` (not empty), the one nearest to ``q``
    in fractions of each range of ``[lo, hi]``, one with a clear straight path first."""
    near = min(found, key=lambda g: (not _clear_path(ok, q, g), _spread(g, q, lo, hi)))
    return goal_error(model, near), near


def _spread(g: FloatArray, q: FloatArray, lo: FloatArray, hi: FloatArray) -> float:
    """The largest joint step from ``q`` to ``g`` in fractions of ``[lo, hi]``."""
    return float(np.max(np.abs(g - q) / (hi - lo)))


def _clear_path(ok: Clear, q: FloatArray, g: FloatArray) -> bool:
    """Whether ``ok`` holds at :data:`PATH_POINTS` configurations evenly spaced on the
    straight joint-space segment from ``q`` (excluded) to ``g`` (included): the terminal
    cost pulls the plan roughly along it, and an obstacle across it holds the arm at
    ``d_safe`` (the horizon is too short to plan round)."""
    return all(ok(q + f * (g - q)) for f in np.linspace(0.0, 1.0, PATH_POINTS + 1)[1:])


PATH_POINTS = 10
"""Configurations checked on the straight path to a candidate goal (:func:`_clear_path`)."""

POSE_SHARE = 3
"""Iterations of the pose stage for each one of the feature stage (:func:`search_steps`): the
pose stage's four exact goals are met in about the periods they took with the stage alone,
the feature stage's goal still in the first periods where the pose stage meets none
(mc05-joint-limits). Measured at N = 200 (docs/results.md, "The Panda's early goal"): with
1 for 1, panda-near-limits 125/132 on the ideal sensor, with 3, 127/132 (mc05 93 and 94/94)."""
