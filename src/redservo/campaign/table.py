"""What a campaign's statistics, report and figures need of its rows, in numpy columns.

The client of a campaign does not keep its rows (they are on disk:
:mod:`redservo.campaign.rowfile`); it keeps, per method and sample, the values the
statistics need (:mod:`redservo.campaign.stats`): a few float64 and boolean columns, so
about 100 bytes per (sample, method) (docs/scaling.md, "Memory"). Medians and percentiles
need every value, hence columns rather than running sums. A row added again for the same
(sample, method) replaces the earlier one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from redservo.campaign.stats import STAT_COLUMNS, MethodStats, column_stats

FLOATS = (*STAT_COLUMNS, "peak_velocity_ratio", "final_error")
"""The float columns kept (``peak_velocity_ratio``: NaN when the row has none)."""


class RunTable:
    """Columns of the rows of ``methods`` x samples ``0..n-1`` (module docstring).

    Args:
        methods: The methods, in table order.
        n: The number of samples.
    """

    def __init__(self, methods: Sequence[str], n: int) -> None:
        self.methods = tuple(methods)
        self.n = int(n)
        self._k = {m: k for k, m in enumerate(self.methods)}
        shape = (len(self.methods), self.n)
        self.present = np.zeros(shape, dtype=bool)
        self.success = np.zeros(shape, dtype=bool)
        self.shield = np.zeros(shape, dtype=bool)
        self.velocity = np.zeros(shape, dtype=bool)
        self.attempts = np.zeros(shape, dtype=np.int64)
        self.outcome = np.full(shape, -1, dtype=np.int16)
        self.reach = np.full(shape, -1, dtype=np.int8)
        """Per row: 1 reachable goal, 0 unreachable, -1 unknown (:mod:`~redservo.campaign.reach`)."""
        self.outcomes: list[str] = []
        self.values = {c: np.full(shape, np.nan) for c in FLOATS}
        self.flags: dict[str, np.ndarray] = {}

    def __contains__(self, key: object) -> bool:
        """``(sample, method)`` has a row."""
        if not isinstance(key, tuple) or len(key) != 2:
            return False
        i, m = key
        k = self._k.get(m)
        return k is not None and 0 <= i < self.n and bool(self.present[k, i])

    def wants(self, sample: int, method: str) -> bool:
        """The pair is one of this table's (sample below ``n``, method listed)."""
        return method in self._k and 0 <= sample < self.n

    def add(self, row: Mapping[str, Any]) -> None:
        """Keep the values of one row (``samples.csv`` columns) of a pair it :meth:`wants`."""
        k, i = self._k[row["method"]], int(row["sample"])
        self.present[k, i] = True
        self.success[k, i] = bool(row["success"])
        self.shield[k, i] = int(row.get("shield_activations") or 0) > 0
        self.velocity[k, i] = int(row.get("velocity_violations") or 0) > 0
        self.attempts[k, i] = int(row["attempts"])
        outcome = str(row["outcome"])
        if float(row.get("min_distance") or 0.0) < 0.0:  # overlapped: a collision, a failure
            outcome = "collision"
        if outcome not in self.outcomes:
            self.outcomes.append(outcome)
        self.outcome[k, i] = self.outcomes.index(outcome)
        reach = str(row.get("reachable") or "")
        self.reach[k, i] = -1 if not reach else int(reach == "True")
        for c in FLOATS:
            v = row.get(c)
            self.values[c][k, i] = np.nan if v is None else float(v)
        for column in self.flags.values():
            column[k, i] = False
        for label in str(row.get("flags") or "").split(";"):
            if label:
                self.flags.setdefault(label, np.zeros_like(self.present))[k, i] = True

    def counts(self) -> dict[str, int]:
        """Rows per method."""
        return {m: int(self.present[k].sum()) for m, k in self._k.items()}

    def pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample numbers and method indices of the rows, sorted by sample then method."""
        samples, methods = np.nonzero(self.present.T)
        return samples, methods

    def redraws(self) -> int:
        """Invalid starts re-drawn: the ``attempts`` summed over the rows of the method of
        the first row (by sample, then method order); 0 without rows."""
        samples, methods = self.pairs()
        if samples.size == 0:
            return 0
        k = int(methods[0])
        return int(self.attempts[k][self.present[k]].sum())

    def stats(self, method: str) -> MethodStats:
        """:class:`MethodStats` of one method's rows, in sample order."""
        k = self._k[method]
        have = self.present[k]
        codes = self.outcome[k][have]
        counts = {o: int((codes == j).sum()) for j, o in enumerate(self.outcomes)}
        flags = {label: int(col[k][have].sum()) for label, col in self.flags.items()}
        reach = self.reach[k][have]
        return column_stats(
            method,
            self.success[k][have],
            counts,
            {c: v[k][have] for c, v in self.values.items()},
            shield_runs=int(self.shield[k][have].sum()),
            velocity_runs=int(self.velocity[k][have].sum()),
            flag_runs=tuple(sorted((lab, c) for lab, c in flags.items() if c)),
            reachable=None if np.all(reach < 0) else reach == 1,
        )

    def box(self, tracking: bool) -> list[list[float]]:
        """The values of the second campaign figure per method, in sample order: the
        iterations of the successes, or (``tracking``) the final error of the runs that
        lasted (outcome ``converged`` or ``max_iterations``)."""
        out = []
        for k in range(len(self.methods)):
            have = self.present[k]
            if tracking:
                lasted = [j for j, o in enumerate(self.outcomes) if o in FULL]
                keep = have & np.isin(self.outcome[k], lasted)
                out.append(self.values["final_error"][k][keep].tolist())
            else:
                keep = have & self.success[k]
                out.append([int(v) for v in self.values["iterations"][k][keep]])
        return out


FULL = ("converged", "max_iterations")
"""Outcomes of the runs that lasted (tracking campaigns' final-error figure)."""
