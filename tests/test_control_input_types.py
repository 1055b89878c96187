"""The compiled controller's kernel sees one type per input whatever the caller's array flags,
so a caller's read-only array compiles nothing new (``make test``: a read-only ``qdot_prev``
compiled the controller's chain anew, 22 kernels, 39 s of one test)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.binding.control import CompiledControl
from redservo.kernels import compiled
from tests.test_public_path_speed import _controller

pytestmark = pytest.mark.skipif(not compiled(), reason="the compiled controller needs numba")


def test_a_read_only_previous_command_reaches_the_kernel_as_a_writable_copy(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The kernel gets a writable copy with the same bits (the plain entry point, not a new
    read-only signature), the caller's array untouched; the command is the object path's."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    seen: list[tuple[bool, bool, bytes]] = []
    run = CompiledControl.run_kernel

    def spy(self: Any, q: Any, packs: tuple[Any, ...], plain: bool = False) -> Any:
        prev = packs[4][2]
        seen.append((plain, bool(prev.flags.writeable), prev.tobytes()))
        return run(self, q, packs, plain)

    monkeypatch.setattr(CompiledControl, "run_kernel", spy)
    prev = np.linspace(-0.01, 0.01, q.shape[0])
    prev.setflags(write=False)
    got = ctl.step(q, meas, 0.0, qdot_prev=prev)
    want = ref.step(q, meas, 0.0, qdot_prev=prev)
    assert seen == [(True, True, prev.tobytes())]
    assert not prev.flags.writeable
    assert got.qdot.tobytes() == want.qdot.tobytes()
