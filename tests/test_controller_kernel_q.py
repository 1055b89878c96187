"""The Controller's step kernel copies ``q`` into its buffer (kernels/control.py ``put_task``):
the quick step (redservo.control.engine.quick_step) then makes no copy of ``q`` in Python;
the command history keeps its joints in its ring's row and the lazy diagnostics read the
kernel's copy. Everything bit for bit the object path's, fuzzed, and the same error on a
bad ``q``."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo import RedservoError
from redservo.control import Measurement
from redservo.kernels import compiled
from redservo.kernels.control import control_layout
from redservo.redundancy import make_law
from tests.test_controller_quick_step import _history, _same_step
from tests.test_public_path_speed import _controller

needs_numba = pytest.mark.skipif(not compiled(), reason="entry points are numba's")

LAWS = ("iterative-smooth", "classical", "qp")


def _with_law(name: str, **options: Any) -> tuple[Any, Any, Measurement]:
    ctl, q, meas = _controller(**options)
    if name != "iterative-smooth":
        from redservo import Controller

        ctl = Controller(
            ctl.robot, ctl.task, make_law(name), ctl.limits, lam=ctl.lam, dt=ctl.dt, **options
        )
    return ctl, q, meas


def test_the_layout_ends_with_the_joints() -> None:
    """``q`` (n) is the last part of the step's buffer (on today's main there is none)."""
    layout = control_layout(6, 8, 8)
    assert layout["q"] == (layout["L"][1], layout["L"][1] + 6)
    assert layout["size"] == (0, layout["q"][1])


@needs_numba
@pytest.mark.parametrize("law", LAWS)
def test_the_kernel_writes_q_and_the_history_keeps_the_rings_row(law: str) -> None:
    """The quick step's buffer holds the kernel's copy of ``q``, and the history's entry
    reads its ring's row (on today's main: a copy of ``q`` made in Python for both)."""
    ctl, q, meas = _with_law(law)
    if ctl._compiled is None or not ctl._quick:
        pytest.skip(f"{law}: no quick compiled step here")
    ctl.step(q, meas, 0.0, qdot_prev=None)  # finds the entry
    step = ctl.step(q, meas, 0.04, qdot_prev=None)
    eng, buf = step._src[:2]
    assert buf[eng.q_part].tobytes() == q.tobytes()
    ring = ctl.history._ring
    assert np.shares_memory(ctl.history._cmds[-1].q, ring.q)
    assert not np.shares_memory(ctl.history._cmds[-1].q, q)


@needs_numba
@pytest.mark.parametrize("law", LAWS)
def test_fuzzed_steps_equal_the_object_paths_with_q_changed_after_each(law: str) -> None:
    """Random joints (some near a limit, where the safety layer acts and the diagnostics
    read ``q``), features and inverse depths: every quick step's command, task state,
    diagnostics (read late, after the caller wrote into its ``q`` and after later steps)
    and the history equal the object path's bit for bit."""
    ctl, q0, meas = _with_law(law)
    ref, _, _ = _with_law(law, engine="python")
    lo, hi = ctl.limits.q_min, ctl.limits.q_max
    rng = np.random.default_rng(29)
    kept = []
    for k in range(40):
        q = q0 + 0.05 * rng.normal(size=q0.shape)
        if k % 3 == 0:  # one joint just inside a limit
            j = int(rng.integers(q.shape[0]))
            q[j] = hi[j] - 1e-3 * (hi[j] - lo[j]) if k % 2 else lo[j] + 1e-3 * (hi[j] - lo[j])
        q = np.clip(q, lo + 1e-6, hi - 1e-6)
        s = meas.s + 1e-3 * rng.normal(size=meas.s.shape)
        iz = tuple(d * (1.0 + 0.1 * rng.random()) for d in meas.inv_depth)
        want = ref.step(q.copy(), Measurement(s, iz), 0.04 * k, qdot_prev=None)
        got = ctl.step(q, Measurement(s, iz), 0.04 * k, qdot_prev=None)
        q[:] = np.nan  # the caller reuses its array: nothing kept may change
        kept.append((got, want))
    for got, want in kept:
        _same_step(got, want)
    assert _history(ctl) == _history(ref)


@needs_numba
@pytest.mark.parametrize("law", LAWS)
def test_a_bad_q_keeps_the_object_paths_error(law: str) -> None:
    """A joint past its limit, NaN, inf, a wrong length: the full path's one error, as the
    object path raises it, after quick steps."""
    ctl, q, meas = _with_law(law)
    ref, _, _ = _with_law(law, engine="python")
    ctl.step(q, meas, 0.0, qdot_prev=None)
    ctl.step(q, meas, 0.04, qdot_prev=None)
    past = q.copy()
    past[2] = ctl.limits.q_max[2] + 0.1
    bad = [past, np.full(q.shape, np.nan), np.full(q.shape, np.inf), q[:-1]]
    for b in bad:
        errors = []
        for c in (ctl, ref):
            with pytest.raises(RedservoError) as info:
                c.step(b, meas, 0.08, qdot_prev=None)
            errors.append((type(info.value), str(info.value), info.value.argument))
        assert errors[0] == errors[1]
