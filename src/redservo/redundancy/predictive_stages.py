"""The two stages of the ``predictive`` law's joint-goal search, seed by seed
(:func:`~redservo.redundancy.predictive_goal.search_steps`; docs/predictive.md, "Joint goal").

Each stage runs from each seed in turn, one iteration (one kinematics evaluation and one
damped least-squares step) per ``yield``: the pose IK of the desired camera pose polished by
feature-space IK (:func:`_pose_stage`), and the feature-space search alone
(:func:`_feature_stage`). With a :class:`~redservo.redundancy.predictive_replan.SeedMemo`
(collision avoidance among static obstacles), what a seed from :data:`RANDOM_FROM` on gave in
an earlier search of the run is taken from the memo, without its iterations. Units: metres,
radians, normalized image coordinates.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from functools import partial

import numpy as np

from redservo._validation import FloatArray
from redservo.redundancy.predictive_model import PointModel, horizon
from redservo.redundancy.predictive_moments import MomentModel
from redservo.redundancy.predictive_replan import SeedMemo

__all__ = ["CANDIDATES", "RANDOM_FROM", "STALL", "TOL", "Best", "Clear", "Met"]

RANDOM_FROM = 7
"""The first seed of a search that does not depend on the configuration: ``q`` and six around
it come first, then the uniform ones (:meth:`~redservo.redundancy.predictive_goal.GoalSearch.
start`); only these are kept in a :class:`~redservo.redundancy.predictive_replan.SeedMemo`."""

STALL = 15
"""Iterations without progress after which :func:`feature_ik` gives up a seed."""

Clear = Callable[[FloatArray], bool]
"""Whether a configuration (rad or m) may be the goal (clear of the obstacles)."""


def _anywhere(q: FloatArray) -> bool:
    """Without obstacles every configuration within the bounds may be the goal."""
    return True


CANDIDATES = 4
"""Exact goals collected before the nearest to ``q`` is chosen (a far goal takes a long
joint-space path, which the image constraint blocks more often)."""

TOL = 1e-5
"""Error ``‖e(q*)‖`` (task units: normalized image coordinates, moments) of a joint goal."""


class Met:
    """The exact goals a running search has met (:func:`search_steps`): those of the pose
    stage in the order met (and their errors ``‖e‖``), and the feature stage's (its result,
    ``(‖e‖, q)``)."""

    def __init__(self) -> None:
        self.pose: list[FloatArray] = []
        self.pose_error: list[float] = []
        self.feature: tuple[float, FloatArray] | None = None


Best = tuple[float, FloatArray | None]
"""A stage's best configuration met ``(‖e‖, q)`` (``(inf, None)``: none)."""


def _pose_stage(
    model: PointModel | MomentModel,
    target: FloatArray,
    seeds: list[FloatArray],
    lo: FloatArray,
    hi: FloatArray,
    ok: Clear,
    met: Met,
    memo: SeedMemo | None = None,
) -> Generator[None, None, Best]:
    """The pose IK of ``target`` from each seed, polished by feature-space IK: each exact
    goal appended to ``met.pose``, until :data:`CANDIDATES` of them; returns the best
    inexact configuration met. ``memo``: what the seeds gave before (module docstring)."""
    from redservo.robots.ik import ik_steps  # scipy: not loaded by ``import redservo``

    def polished(seed: FloatArray) -> Generator[None, None, Best]:
        qs = yield from ik_steps(model.robot, target, seed, lo, hi)
        if qs is None:  # no pose IK: as no configuration
            return np.inf, None
        return (yield from _ik_from(model, qs, lo, hi, 30, TOL))

    best: Best = (np.inf, None)
    for i, seed in enumerate(seeds):
        r, qp = yield from _recalled(memo, "pose", i, partial(polished, seed))
        if qp is not None and not ok(qp):
            continue
        if r < TOL and qp is not None:
            met.pose.append(qp)
            met.pose_error.append(r)
            if len(met.pose) == CANDIDATES:
                break
        best = min(best, (r, qp), key=lambda b: b[0])
    return best


def _feature_stage(
    model: PointModel | MomentModel,
    seeds: list[FloatArray],
    lo: FloatArray,
    hi: FloatArray,
    ok: Clear,
    met: Met,
    memo: SeedMemo | None = None,
) -> Generator[None, None, Best]:
    """Feature-space IK from each seed in turn until one reaches an exact goal (set as
    ``met.feature``); returns the best configuration met before it. ``memo``: what the
    seeds gave before (module docstring)."""
    best: Best = (np.inf, None)
    for i, seed in enumerate(seeds):
        start = np.clip(seed, lo, hi)
        r, qp = yield from _recalled(
            memo, "feature", i, partial(_ik_from, model, start, lo, hi, 100, TOL)
        )
        if qp is not None and not ok(qp):
            continue
        if r < TOL and qp is not None:
            met.feature = (r, qp)
            break
        best = min(best, (r, qp), key=lambda b: b[0])
    return best


def _recalled(
    memo: SeedMemo | None, stage: str, i: int, run: Callable[[], Generator[None, None, Best]]
) -> Generator[None, None, Best]:
    """What seed ``i`` gives in ``stage``: from ``memo`` when it is known there (no
    iteration), else ``run()``'s iterations, kept in ``memo`` (seeds from
    :data:`RANDOM_FROM` on)."""
    keep = memo is not None and i >= RANDOM_FROM
    out = memo.get(stage, i) if keep and memo is not None else None
    if out is None:
        out = yield from run()
        if keep and memo is not None:
            memo.put(stage, i, out)
    return out


def _ik_from(
    model: PointModel | MomentModel,
    q: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    iterations: int,
    tol: float,
) -> Generator[None, None, tuple[float, FloatArray | None]]:
    """Projected damped least squares on ``e(q) = C (s(q) - s*)`` within ``[lo, hi]`` from
    ``q``: ``(error, q)`` of the best configuration met (``error < tol``: converged; ``inf,
    None``: the prediction failed at the seed). A seed is given up when its error has not
    fallen below 0.99 of its best for :data:`STALL` iterations (stuck against the bounds or
    in a local minimum). One iteration per ``yield`` (:func:`search_steps`)."""
    from redservo.robots.ik import Stall, projected_step  # scipy: not loaded by ``import redservo``

    hz = horizon(1, 1)
    best: tuple[float, FloatArray | None] = (np.inf, None)
    stalled = Stall(STALL)
    for _ in range(iterations):
        pred = model.predict(q, np.zeros((1, q.shape[0])), hz, 0.0)
        if pred is None:
            return best
        e, G = pred.e[0], pred.G[0]
        if not (np.all(np.isfinite(G)) and np.all(np.isfinite(e))):
            return best
        size = float(np.linalg.norm(e))
        if stalled(size):  # stuck against the bounds or in a local minimum
            return best
        if stalled.since == 0:
            best = (size, q)
        if size < tol:
            return best
        nxt = projected_step(G, -e, q, lo, hi, 1e-3, 0.3)
        if nxt is None:
            return best
        q = nxt
        yield
    return best
