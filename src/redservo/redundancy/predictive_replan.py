"""When the ``predictive`` law's joint-goal search starts again, and what a new search may
reuse of the previous ones (docs/predictive.md, "Joint goal"; issue 30's speed target).

Both rules hold only in a run that avoids collisions among static obstacles (the law's
``goal_clearance`` is on, :func:`~redservo.redundancy.predictive_distance.static_scene`):
runs without collision avoidance keep the search exactly as before, bit for bit.

* **Seed memo** (:class:`SeedMemo`). A search
  (:func:`~redservo.redundancy.predictive_goal.search_steps`) runs the pose IK and the
  feature-space search from 67 seeds; the last :data:`~redservo.redundancy.predictive_goal.
  RANDOM_FROM` on are drawn uniformly within the bounds by a generator seeded with 0, the
  same in every search. While the model's target, the desired camera pose ``bMc*`` and the
  bounds are those of the previous search (within :data:`SAME`), what such a seed gives (its
  configuration and error, or nothing) is a function of the seed alone: a new search takes it
  from the memo instead of running its iterations again. The goals are the ones the full
  search would find, in the same order; only the periods the search takes change (a run held
  at ``d_safe`` by a post restarted a failing search of about 5 000 iterations, 250 periods,
  from its held configuration).
* **Deferred restart** (:class:`Replan`). A search is due ``replan`` periods after the
  previous one started, once that one is over. When a search ends without a new goal (none,
  or within :data:`SAME_GOAL` of the one before) while the configuration has moved less than
  :data:`MOVED` of each joint's range since it started and the target stayed where it was,
  the same search would find the same nothing: the next one waits until the configuration
  moves by :data:`MOVED` from that start, the target moves, or ``HOLD · replan · 2^(k-1)``
  periods have passed since the search ended (``k``: such searches in a row; a found goal or
  a move resets ``k``).

Units: radians or metres (joints), metres (the target's points), periods.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import TYPE_CHECKING

import numpy as np

from redservo._validation import FloatArray
from redservo.redundancy.predictive_model import PointModel

if TYPE_CHECKING:
    from redservo.redundancy.predictive_moments import MomentModel

__all__ = ["HOLD", "MOVED", "SAME", "SAME_GOAL", "Replan", "SeedMemo", "model_key"]

SAME = 1e-9
"""Largest difference (m, normalized image units, rad or m) of the memo's key entries that
still counts as the same search (:class:`SeedMemo`): the desired camera pose is found by
virtual visual servoing to ``‖s − s*‖ < 1e-10`` from wherever the camera is."""

MOVED = 1e-2
"""A move of the configuration (fraction of a joint's range, largest over the joints) that
makes a deferred search due again (:class:`Replan`): 1 %, the scale of the joint band and
of the success margin, a fifteenth of the spread of the seeds drawn around ``q``. Between two
searches a run held at ``d_safe`` moves by 1e-7 of a range (panda-posts sample 3, seed 0),
one creeping along an obstacle by 1e-3 to 5e-3 (samples 6 and 8), one still on its way by
2e-2 and more (sample 7)."""

SAME_GOAL = 1e-6
"""A search's goal within this fraction of each joint's range of the goal before it is no
new goal (:class:`Replan`)."""

HOLD = 8
"""A deferred search waits at most ``HOLD · replan`` periods after the futile search ended
(doubled after each further futile search in a row)."""


def model_key(model: PointModel | MomentModel) -> FloatArray:
    """What a goal search depends on in the model: its target's points in the base frame
    ``P_b`` (point model) or its target pose ``bMo`` (moments), ``s*`` and ``C``."""
    target = model.P_b if isinstance(model, PointModel) else model.bMo
    parts = [np.ravel(target), np.ravel(model.s_star)]
    return np.concatenate(parts + ([] if model.C is None else [np.ravel(model.C)]))


def _same(a: FloatArray | None, b: FloatArray | None, tol: float) -> bool:
    if a is None or b is None:
        return a is b
    return a.shape == b.shape and bool(np.all(np.abs(a - b) <= tol))


class SeedMemo:
    """What each seed not drawn around ``q`` gave in the searches of one run (module
    docstring): ``(error, configuration or None)`` per ``(stage, seed index)``."""

    def __init__(self) -> None:
        self._key: FloatArray | None = None
        self._out: dict[Hashable, tuple[float, FloatArray | None]] = {}
        self.hits = 0
        """Seeds taken from the memo since the run began (a diagnostic)."""

    def reset(self) -> None:
        """Forget everything (a new run)."""
        self._key, self._out, self.hits = None, {}, 0

    def bind(self, key: FloatArray) -> None:
        """The key of the search about to run: the memo is kept if it is the previous
        search's (within :data:`SAME`), else emptied."""
        if not _same(self._key, key, SAME):
            self._out = {}
        self._key = key

    def get(self, stage: str, i: int) -> tuple[float, FloatArray | None] | None:
        """What seed ``i`` gave in ``stage`` (None: not known)."""
        out = self._out.get((stage, i))
        self.hits += out is not None
        return out

    def put(self, stage: str, i: int, out: tuple[float, FloatArray | None]) -> None:
        """Keep what seed ``i`` gave in ``stage``."""
        self._out[(stage, i)] = out


class Replan:
    """When the joint-goal search starts (module docstring): ``replan`` periods after the
    previous start, deferred after a futile search when ``defer`` is on."""

    def __init__(self, replan: int) -> None:
        self.replan = replan
        self.reset()

    def reset(self) -> None:
        """A new run: the first call is due."""
        self.started: int | None = None
        self._from: tuple[FloatArray, FloatArray, FloatArray | None] | None = None
        self._hold: tuple[FloatArray, FloatArray, int] | None = None
        self.futile = 0
        """Futile searches in a row (the deferral's doubling)."""

    def due(self, calls: int, q: FloatArray, span: FloatArray, key: FloatArray) -> bool:
        """Whether a search starts at call ``calls`` from ``q`` (``span``: the joints'
        ranges) with the model's :func:`model_key` ``key``."""
        if self.started is not None and calls - self.started < self.replan:
            return False
        if self._hold is None:
            return True
        q0, key0, until = self._hold
        moved = float(np.max(np.abs(q - q0) / span)) > MOVED
        if moved or not _same(key0, key, SAME):
            self.futile = 0
        elif calls < until:
            return False
        self._hold = None
        return True

    def start(self, calls: int, q: FloatArray, key: FloatArray, goal: FloatArray | None) -> None:
        """A search starts at call ``calls`` from ``q``; ``goal``: the goal before it."""
        self.started = calls
        self._from = (q.copy(), key, None if goal is None else goal.copy())

    def end(
        self,
        calls: int,
        q: FloatArray,
        span: FloatArray,
        key: FloatArray,
        goal: FloatArray | None,
        defer: bool,
    ) -> None:
        """The search ended at call ``calls`` at ``q`` with the law's ``goal``: a futile one
        defers the next when ``defer`` (collision avoidance among static obstacles)."""
        if self._from is None:
            return
        q0, key0, goal0 = self._from
        self._from = None
        new_goal = not _same(
            None if goal0 is None else goal0 / span,
            None if goal is None else goal / span,
            SAME_GOAL,
        )
        still = float(np.max(np.abs(q - q0) / span)) <= MOVED and _same(key0, key, SAME)
        if not (defer and still and not new_goal):
            self.futile = 0
            return
        self.futile += 1
        self._hold = (q0, key0, calls + HOLD * self.replan * 2 ** (self.futile - 1))
