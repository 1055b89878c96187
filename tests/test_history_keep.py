"""The command history's entry (``CommandHistory.keep``, written at every control step,
issue 29 item 3): its ring of times and flags is written item by item through memoryviews
instead of numpy's scalar indexing; the commands, the ring, its head and the order flag
are those of the numpy writes, entry for entry, whatever the times."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pytest

from redservo.control.latency import CommandHistory


class _Reference:
    """``CommandHistory.keep`` as it was written with numpy's scalar indexing (the ring's
    capacity read from its array), the reference of the fuzz test."""

    def __init__(self, horizon: float) -> None:
        self.horizon, self.cmds, self.ordered = horizon, deque[Any](), True
        self.t, self.has, self.head = np.zeros(64), np.zeros(64, dtype=np.bool_), 0

    def keep(self, t: float, q: Any, qdot: Any) -> None:
        cmds = self.cmds
        if cmds and t < cmds[-1][0]:
            self.ordered = False
        cmds.append((t, q, qdot))
        cap = self.t.shape[0]
        if len(cmds) > cap:  # twice the slots, the kept ones first
            order = (self.head + np.arange(len(cmds) - 1)) % cap
            t_old, has_old = self.t[order], self.has[order]
            self.t, self.has = np.zeros(2 * cap), np.zeros(2 * cap, dtype=np.bool_)
            self.t[: len(order)], self.has[: len(order)], self.head = t_old, has_old, 0
        slot = (self.head + len(cmds) - 1) % self.t.shape[0]
        self.t[slot] = t
        self.has[slot] = False
        while cmds[0][0] < t - self.horizon:
            cmds.popleft()
            self.head = (self.head + 1) % self.t.shape[0]


@pytest.mark.parametrize("seed", range(6))
def test_the_ring_written_item_by_item_is_the_numpy_writes(seed: int) -> None:
    """Random periods (growth past 64 commands included), times that go back now and then,
    resets and twists marked known in between: after every command the history's entries,
    ring, head, capacity and order flag equal the reference's."""
    rng = np.random.default_rng(seed)
    horizon = float(rng.choice([0.05, 0.3, 1.0, 5.0]))
    hist, ref = CommandHistory(0.01, lambda q: np.zeros((6, 2)), horizon), _Reference(horizon)
    t = 0.0
    for k in range(600):
        t += float(rng.choice([0.001, 0.004, 0.02, -0.003]))
        q, qdot = rng.normal(size=2), rng.normal(size=2)
        hist.keep(t, q, qdot)
        ref.keep(t, q, qdot)
        ring = hist._ring
        assert [(c.t, c.q, c.qdot) for c in hist._cmds] == list(ref.cmds), k
        assert ring.t.tobytes() == ref.t.tobytes() and ring.head == ref.head, k
        assert ring.cap == ring.t.shape[0] == ring.has.shape[0], k
        assert hist._ordered == ref.ordered, k
        if rng.random() < 0.05:  # motion() marks twists known in its slots
            ring.has[:] = ref.has[:] = rng.random(ring.cap) < 0.5
        assert ring.has.tobytes() == ref.has.tobytes(), k
        if rng.random() < 0.01:
            hist.reset()
            ref = _Reference(horizon)
            ref.t, ref.has = ring.t.copy(), ring.has.copy()  # reset keeps the slots' values


def test_a_grown_ring_writes_into_its_new_arrays() -> None:
    """After the ring doubles, the item views are those of the new arrays (a write through a
    view of the old ones would be lost)."""
    hist = CommandHistory(0.01, lambda q: np.zeros((6, 1)), horizon=10.0)
    for k in range(200):
        hist.keep(0.01 * k, np.zeros(1), np.zeros(1))
    ring = hist._ring
    assert ring.cap == 256
    assert ring.t[:200].tolist() == [0.01 * k for k in range(200)]
    assert not ring.has.any()


@pytest.mark.parametrize("seed", range(4))
def test_commands_kept_in_the_ring_read_as_they_were_sent(seed: int) -> None:
    """The compiled step's commands kept in the ring's slots only (``in_ring``: its buffer
    is written again by the next step): every entry still in the history reads the command
    it was given, through growth past 64 commands, entries leaving and slots reused, and
    equals a history of copies entry for entry."""
    rng = np.random.default_rng(seed)
    horizon = float(rng.choice([0.05, 0.5, 2.0]))
    ring_kept = CommandHistory(0.01, lambda q: np.zeros((6, 3)), horizon)
    copies = CommandHistory(0.01, lambda q: np.zeros((6, 3)), horizon)
    buf, part = np.empty(10), slice(2, 5)
    t = 0.0
    for k in range(500):
        t += float(rng.choice([0.002, 0.01, 0.03, -0.004]))
        q = rng.normal(size=3)
        buf[:] = rng.normal(size=10)  # the kernel writes the reused buffer
        ring_kept.keep(t, q, buf, part, True)
        copies.keep(t, q, buf[part].copy())
        got = [(c.t, c.q.tobytes(), c.qdot.tobytes()) for c in ring_kept._cmds]
        assert got == [(c.t, c.q.tobytes(), c.qdot.tobytes()) for c in copies._cmds], k
        assert ring_kept._ring.qdot.tobytes() == copies._ring.qdot.tobytes(), k
        assert ring_kept._cmds[-1].qdot.base is not buf  # never a view of the buffer
