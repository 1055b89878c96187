"""The per-iteration log of a run, shared by the simulator and the hardware servo loop."""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics
from redservo.redundancy.flags import FLAGS, Flag
from redservo.task import TaskState

__all__ = ["FLAG_COLUMNS", "LogBuffer", "SimulationLog"]

FLAG_COLUMNS: tuple[str, ...] = tuple(f"flag.{f.label}" for f in FLAGS)
"""CSV column of each diagnostic flag: the number attached to it at that step, NaN when not raised."""
_FLAG_INDEX = {f: i for i, f in enumerate(FLAGS)}


@dataclass
class SimulationLog:
    """Per-iteration log of a run; row i is iteration i. Arrays are (N, ·).

    ``flags`` is (N, F), one column per :class:`~redservo.Flag` in ``FLAGS`` order, holding
    the number attached to the flag at that step (NaN when it was not raised).
    """

    t: FloatArray
    q: FloatArray
    qdot: FloatArray
    camera_twist: FloatArray
    s: FloatArray
    e: FloatArray
    e1: FloatArray
    error_norm: FloatArray
    q_normalized: FloatArray
    alpha: FloatArray
    projector_rank: FloatArray
    task_rank: FloatArray
    levels: FloatArray
    overconstrained: FloatArray
    constrained: FloatArray
    gamma: FloatArray
    scale: FloatArray
    flags: FloatArray | None = None
    min_distance: FloatArray | None = None
    """(N,) the smallest distance (m) over the collision pairs at each step (NaN: not
    measured, no obstacle and no self pair)."""
    closest_pair: FloatArray | None = None
    """(N,) index into :attr:`pair_names` of the pair at :attr:`min_distance` (-1: none)."""
    diagnostics: list[Diagnostics] = field(default_factory=list, repr=False)
    joint_names: tuple[str, ...] = ()
    feature_names: tuple[str, ...] = ()
    pair_names: tuple[str, ...] = ()
    """The closest pairs met, ``"link/obstacle"`` or ``"link/link"``."""

    _ARRAYS = (
        "t",
        "q",
        "qdot",
        "camera_twist",
        "s",
        "e",
        "e1",
        "error_norm",
        "q_normalized",
        "alpha",
        "projector_rank",
        "task_rank",
        "levels",
        "overconstrained",
        "constrained",
        "gamma",
        "scale",
        "flags",
        "min_distance",
        "closest_pair",
    )

    def __post_init__(self) -> None:
        if self.flags is None:
            self.flags = np.full((len(self), len(FLAGS)), np.nan)
        if self.min_distance is None:
            self.min_distance = np.full(len(self), np.nan)
        if self.closest_pair is None:
            self.closest_pair = np.full(len(self), -1.0)

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def arrays(self) -> dict[str, FloatArray]:
        """Return the logged arrays by name."""
        return {name: getattr(self, name) for name in self._ARRAYS}

    def flag(self, flag: Flag) -> FloatArray:
        """(N,) the number attached to ``flag`` at each step (NaN when not raised)."""
        assert self.flags is not None
        return np.asarray(self.flags[:, _FLAG_INDEX[flag]])

    def save_npz(self, path: str | Path) -> None:
        """Save every array to a compressed ``.npz`` (plus joint, feature and flag names)."""
        data: dict[str, Any] = {
            **self.arrays(),
            "joint_names": np.array(self.joint_names),
            "feature_names": np.array(self.feature_names),
            "flag_names": np.array([f.label for f in FLAGS]),
            "pair_names": np.array(self.pair_names, dtype=str),
        }
        np.savez_compressed(path, **data)

    def save_csv(self, path: str | Path) -> None:
        """Save one row per iteration; vector columns are split as ``name[i]`` (0-based),
        flags as ``flag.<label>``, the closest pair by its name (empty: none)."""
        cols: list[str] = []
        blocks: list[FloatArray] = []
        for name, arr in self.arrays().items():
            a = arr.reshape(len(self), int(np.prod(arr.shape[1:])))  # also for an empty log
            if name == "flags":
                cols.extend(FLAG_COLUMNS)
            elif a.shape[1] == 1:
                cols.append(name)
            else:
                cols.extend(f"{name}[{i}]" for i in range(a.shape[1]))
            blocks.append(a.astype(float))
        table = np.hstack(blocks) if blocks else np.zeros((0, 0))
        pair = cols.index("closest_pair")
        names = (*self.pair_names, "")  # index -1: no pair
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(cols)
            for row in table:
                cells = [f"{v:.10g}" for v in row]
                cells[pair] = names[int(row[pair])]
                w.writerow(cells)


class LogBuffer:
    """Preallocated rows of a run (the simulator's and the servo loop's recorder).

    Args:
        capacity: Maximum number of rows, or None for no cap (a servo loop on hardware).
        n: Joints; k: stacked feature components; m: task dimension.
    """

    _FIRST = 1024
    """Rows allocated at first; the buffer doubles as it fills (up to ``capacity``), so a
    huge iteration cap costs nothing until it is used."""

    def __init__(self, capacity: int | None, n: int, k: int, m: int) -> None:
        self.capacity = capacity
        self.rows = 0
        self.diagnostics: list[Diagnostics] = []
        self.pairs: list[str] = []
        first = self._FIRST if capacity is None else min(capacity, self._FIRST)
        self.buf = self._alloc(first, n, k, m)

    @staticmethod
    def _alloc(N: int, n: int, k: int, m: int) -> dict[str, FloatArray]:
        return {
            "t": np.zeros(N),
            "q": np.zeros((N, n)),
            "qdot": np.zeros((N, n)),
            "camera_twist": np.zeros((N, 6)),
            "s": np.zeros((N, k)),
            "e": np.zeros((N, k)),
            "e1": np.zeros((N, m)),
            "error_norm": np.zeros(N),
            "q_normalized": np.zeros((N, n)),
            "alpha": np.full(N, np.nan),
            "projector_rank": np.zeros(N),
            "task_rank": np.zeros(N),
            "levels": np.zeros(N),
            "overconstrained": np.zeros(N),
            "constrained": np.zeros((N, n)),
            "gamma": np.zeros((N, n)),
            "scale": np.full(N, np.nan),
            "flags": np.full((N, len(FLAGS)), np.nan),
            "min_distance": np.full(N, np.nan),
            "closest_pair": np.full(N, -1.0),
        }

    def _grow(self) -> None:
        old = self.buf
        size = 2 * old["t"].shape[0]
        if self.capacity is not None:
            size = min(self.capacity, size)
        n, k, m = old["q"].shape[1], old["s"].shape[1], old["e1"].shape[1]
        new = self._alloc(size, n, k, m)
        for name, arr in old.items():
            new[name][: self.rows] = arr[: self.rows]
        self.buf = new

    def append(
        self,
        t: float,
        q: FloatArray,
        qdot: FloatArray,
        twist: FloatArray,
        state: TaskState,
        lim: JointLimits,
        d: Diagnostics,
        closest: tuple[float, str] | None = None,
    ) -> None:
        """Record one iteration: time (s), joints, the command, the camera twist, the task
        state the law saw, the law's diagnostics and, when measured, the smallest collision
        distance (m) and its pair."""
        if self.rows == self.buf["t"].shape[0]:
            self._grow()
        buf, i = self.buf, self.rows
        buf["t"][i] = t
        buf["q"][i] = q
        buf["qdot"][i] = qdot
        buf["camera_twist"][i] = twist
        buf["s"][i] = state.s
        buf["e"][i] = state.e
        buf["e1"][i] = state.e1
        buf["error_norm"][i] = float(np.linalg.norm(state.e1))
        buf["q_normalized"][i] = lim.normalized(q)
        if d.alpha is not None:
            buf["alpha"][i] = d.alpha
        buf["projector_rank"][i] = d.projector_rank
        buf["task_rank"][i] = d.task_rank
        buf["levels"][i] = d.iterations
        buf["overconstrained"][i] = float(d.overconstrained)
        for level in d.critical:
            buf["constrained"][i, list(level)] = 1.0
        if d.gamma is not None:
            buf["gamma"][i] = d.gamma
        if d.scale is not None:
            buf["scale"][i] = d.scale
        for ev in d.events:
            j = _FLAG_INDEX[ev.flag]
            if np.isnan(buf["flags"][i, j]):
                buf["flags"][i, j] = ev.value if np.isfinite(ev.value) else 1.0
        if closest is not None and closest[1]:
            if closest[1] not in self.pairs:
                self.pairs.append(closest[1])
            buf["min_distance"][i] = closest[0]
            buf["closest_pair"][i] = self.pairs.index(closest[1])
        self.diagnostics.append(d)
        self.rows = i + 1

    def to_log(self, joint_names: tuple[str, ...], feature_names: tuple[str, ...]) -> SimulationLog:
        """The rows recorded so far as a :class:`SimulationLog`."""
        r = self.rows
        return SimulationLog(
            **{name: arr[:r].copy() for name, arr in self.buf.items()},
            diagnostics=self.diagnostics,
            joint_names=joint_names,
            feature_names=feature_names,
            pair_names=tuple(self.pairs),
        )
