"""What a run's summary says about its distances: the minimum per pair kind and the steps
spent within ``d_influence`` (:class:`DistanceTally`). Units: m."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["DistanceTally"]


@dataclass
class DistanceTally:
    """Accumulates each step's pair distances (a
    :class:`~redservo.control.avoidance.PairDistances`: ``d`` and ``kinds``).

    Attributes:
        d_influence: ``d_i`` (m): a step counts when some pair is closer than this.
        minimum: Per pair kind (``"environment"``, ``"self"``), the smallest distance (m).
        within: Steps with some pair closer than ``d_influence``.
    """

    d_influence: float
    minimum: dict[str, float] = field(default_factory=dict)
    within: int = 0

    def add(self, pd: Any) -> None:
        """Count one step's distances ``pd`` (``pd.d`` (P,) in m, ``pd.kinds`` (P,))."""
        d = np.asarray(pd.d, dtype=float)
        if d.size == 0:
            return
        kinds = np.asarray(pd.kinds)
        for kind in ("environment", "self"):
            mine = d[kinds == kind]
            if mine.size:
                self.minimum[kind] = min(self.minimum.get(kind, np.inf), float(mine.min()))
        self.within += int(float(d.min()) < self.d_influence)

    def fields(self) -> dict[str, Any]:
        """The summary's ``min_distance_by_kind`` and ``steps_within_influence``."""
        return {
            "min_distance_by_kind": dict(self.minimum) or None,
            "steps_within_influence": self.within,
        }
