"""Controller.step's quick path (redservo.control.engine.quick_step, issue 29 item 3): once
the kernel's entry is known, the step a loop repeats is one Python function around it, with
the command, task state, diagnostics and history of the full path bit for bit; every other
input takes the full path and keeps its one clear error."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import redservo.control.engine as engine
from redservo import RedservoError
from redservo.binding.control import CompiledControl
from redservo.control import Measurement
from redservo.kernels import compiled
from tests.test_public_path_speed import _controller, _same_diag

needs_numba = pytest.mark.skipif(not compiled(), reason="entry points are numba's")


def _refuse(*_: Any, **__: Any) -> Any:
    raise AssertionError("the full compiled path was taken")


def _same_step(got: Any, want: Any) -> None:
    assert got.qdot.tobytes() == want.qdot.tobytes()
    _same_diag(got.diagnostics, want.diagnostics)
    for a, b in zip(got.state, want.state, strict=True):
        assert np.asarray(a).tobytes() == np.asarray(b).tobytes()
    assert (got.secondary, got.de1_dt, got.stop, got.saturated) == (None, None, None, False)


def _history(ctl: Any) -> list[bytes]:
    return [c.q.tobytes() + c.qdot.tobytes() + np.float64(c.t).tobytes() for c in ctl.history._cmds]


@needs_numba
@pytest.mark.parametrize("prev", [False, True])
def test_the_repeated_step_is_one_function_around_the_entry_with_the_same_results(
    prev: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """After the first step, neither CompiledControl.step nor its inverse-depth
    concatenation runs (on today's main every step goes through both), and every step's
    command, task state, diagnostics and history are the object path's bit for bit."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    qdot = np.zeros(q.shape[0]) if prev else None
    rng = np.random.default_rng(5)
    for k in range(4):
        m = Measurement(meas.s + 1e-3 * rng.normal(size=meas.s.shape), meas.inv_depth)
        got = ctl.step(q, m, 0.04 * k, qdot_prev=qdot)
        want = ref.step(q, m, 0.04 * k, qdot_prev=qdot)
        _same_step(got, want)
        assert ctl.stage == "guard"
        if k == 0:
            monkeypatch.setattr(CompiledControl, "step", _refuse)
            monkeypatch.setattr(CompiledControl, "_inverse_depths", _refuse)
        qdot = got.qdot.copy() if prev else None
    assert _history(ctl) == _history(ref)


@needs_numba
def test_a_steps_results_do_not_change_with_the_next_step() -> None:
    """The inverse depths' buffer is the controller's, written at every step: what an
    earlier step returned (its task state, its lazy diagnostics read late) stays as it was."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    ctl.step(q, meas, 0.0, qdot_prev=None)  # finds the entry
    first = ctl.step(q, meas, 0.04, qdot_prev=None)
    want = ref.step(q, meas, 0.04, qdot_prev=None)
    far = Measurement(meas.s[::-1].copy(), tuple(2.0 * d for d in meas.inv_depth))
    ctl.step(q, far, 0.08, qdot_prev=None)
    _same_step(first, want)  # the diagnostics are built here, after the later step


def _bad_inputs(q: Any, meas: Measurement) -> list[tuple[str, dict[str, Any]]]:
    iz = meas.inv_depth
    return [
        ("q", {"q": q[:-1]}),
        ("q", {"q": np.full(q.shape, np.nan)}),
        ("t", {"t": float("nan")}),
        ("t", {"t": "0.1"}),
        ("measurement.s", {"measurement": Measurement(meas.s[:-1], iz)}),
        ("measurement.inv_depth", {"measurement": Measurement(meas.s, iz[:-1])}),
        ("measurement", {"measurement": None}),
        ("qdot_prev", {"qdot_prev": np.zeros(q.shape[0] + 1)}),
    ]


@needs_numba
@pytest.mark.parametrize("index", range(8))
def test_a_bad_input_after_the_first_step_keeps_its_one_clear_error(index: int) -> None:
    """The same error, naming the same argument, as on the full path (the object path's)."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    ctl.step(q, meas, 0.0, qdot_prev=None)
    argument, change = _bad_inputs(q, meas)[index]
    kw: dict[str, Any] = {"q": q, "measurement": meas, "t": 0.04, "qdot_prev": None} | change
    errors = []
    for c in (ctl, ref):
        with pytest.raises(RedservoError) as info:
            c.step(kw["q"], kw["measurement"], kw["t"], qdot_prev=kw["qdot_prev"])
        errors.append((type(info.value), str(info.value), info.value.argument))
    assert errors[0] == errors[1]
    assert argument in (errors[0][2] or "")


@needs_numba
@pytest.mark.parametrize(
    ("change", "quick"),
    [
        ({"q": "float32"}, False),
        ({"q": "strided"}, False),
        ({"qdot_prev": "readonly"}, False),
        ({"stamp": 0.0}, False),
        ({"inv_depth": "lists"}, True),
        ({"inv_depth": "float32"}, True),
        ({"q": "tagged"}, False),
        ({"s": "tagged"}, False),
        ({"qdot_prev": "tagged"}, False),
        ({"inv_depth": "tagged"}, True),
    ],
)
def test_another_type_or_layout_gives_the_full_paths_results(
    change: dict[str, Any], quick: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A float32 or strided ``q``, a read-only ``qdot_prev``, a stamped measurement take
    the full path; inverse depths as one-element lists or float32 arrays (what
    ``np.concatenate`` takes too) the quick one: the object path's results either way.
    Float64 arrays whose dtype is equal to numpy's float64 but not it (``tagged``: with
    metadata) take the full path, or numpy's conversion for the inverse depths."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    ctl.step(q, meas, 0.0, qdot_prev=None)
    taken: list[bool] = []
    run = engine.quick_step

    def spy(*args: Any) -> Any:
        done = run(*args)
        taken.append(done is not None)
        return done

    monkeypatch.setattr("redservo.control.controller.quick_step", spy)
    qq: Any = q
    tagged = np.dtype(np.float64, metadata={"unit": "rad"})  # == float64, not float64
    if change.get("q") == "float32":
        qq = q.astype(np.float32)
    elif change.get("q") == "tagged":
        qq = q.astype(tagged)
    elif change.get("q") == "strided":
        qq = np.repeat(q, 2)[::2]
    iz: Any = meas.inv_depth
    if change.get("inv_depth") == "float32":
        iz = tuple(d.astype(np.float32) for d in iz)
    elif change.get("inv_depth") == "lists":
        iz = tuple([float(d[0])] for d in iz)
    elif change.get("inv_depth") == "tagged":
        iz = tuple(d.astype(tagged) for d in iz)
    prev = np.zeros(q.shape[0], dtype=tagged if change.get("qdot_prev") == "tagged" else None)
    prev.setflags(write=change.get("qdot_prev") != "readonly")
    s = meas.s.astype(tagged) if change.get("s") == "tagged" else meas.s
    m = Measurement(s, iz, 0.04 if "stamp" in change else None)
    got = ctl.step(qq, m, 0.04, qdot_prev=prev)
    want = ref.step(qq, m, 0.04, qdot_prev=prev)
    assert got.qdot.tobytes() == want.qdot.tobytes()
    _same_diag(got.diagnostics, want.diagnostics)
    assert taken == [quick]


@needs_numba
def test_an_output_option_set_after_construction_takes_the_full_path() -> None:
    """The output saturation set on a controller whose steps took the quick path: the next
    step is saturated as the object path's (the set-up is read at every step)."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    ctl.step(q, meas, 0.0, qdot_prev=None)
    ctl.qdot_saturation = ref.qdot_saturation = np.full(q.shape[0], 1e-3)
    got, want = ctl.step(q, meas, 0.04, qdot_prev=None), ref.step(q, meas, 0.04, qdot_prev=None)
    assert got.saturated and want.saturated
    assert got.qdot.tobytes() == want.qdot.tobytes()


def test_inverse_depths_not_one_per_point_get_the_object_paths_error() -> None:
    """Four numbers in the first point's entry and none in the others: the compiled engine
    no longer takes them for one per point (on today's main it did, while the object path
    refuses them); the step raises the object path's error naming the entry."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    flat = (np.concatenate(meas.inv_depth), *(np.zeros(0) for _ in meas.inv_depth[1:]))
    errors = []
    for c in (ctl, ref):
        c.step(q, meas, 0.0, qdot_prev=None)
        with pytest.raises(RedservoError) as info:
            c.step(q, Measurement(meas.s, flat), 0.04, qdot_prev=None)
        errors.append((type(info.value), str(info.value), info.value.argument))
    assert errors[0] == errors[1]
    assert errors[0][2] == "inv_depth[0]"
