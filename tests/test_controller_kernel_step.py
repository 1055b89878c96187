"""Controller.step's result on the compiled engine (issue 29 item 3): a ControlStep made from
the kernel's buffer when read (redservo.control.kernel_step), equal to the object path's and
behaving as the NamedTuple it replaces; the law's options and the inverse depths as the
object path takes them."""

from __future__ import annotations

import copy
import pickle
import weakref
from typing import Any

import numpy as np
import pytest

from redservo import RedservoError
from redservo.control import ControlStep, Measurement
from redservo.kernels import compiled
from tests.test_controller_quick_step import _same_step
from tests.test_public_path_speed import _controller, _same_diag

needs_numba = pytest.mark.skipif(not compiled(), reason="entry points are numba's")


def _pair(**options: Any) -> tuple[Any, Any, Any, Measurement]:
    """A compiled controller whose entry is found, the object path's, ``q`` and a measurement."""
    ctl, q, meas = _controller(**options)
    ref, _, _ = _controller(engine="python", **options)
    for c in (ctl, ref):
        c.step(q, meas, 0.0, qdot_prev=None)
    return ctl, ref, q, meas


@needs_numba
def test_the_repeated_step_makes_its_task_state_and_diagnostics_only_when_read(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """No views, task state, copies of the command or options per step (on today's main the
    step builds them all with ``results``); read late, they are the object path's bit for bit."""

    def refuse(*_: Any) -> Any:
        raise AssertionError("the results were built at the step")

    monkeypatch.setattr("redservo.control.engine.results", refuse, raising=False)
    ctl, ref, q, meas = _pair()
    got = ctl.step(q, meas, 0.04, qdot_prev=None)
    want = ref.step(q, meas, 0.04, qdot_prev=None)
    assert isinstance(got, ControlStep) and not vars(got)  # nothing made yet
    ctl.step(q, Measurement(meas.s[::-1].copy(), meas.inv_depth), 0.08, qdot_prev=None)
    _same_step(got, want)  # made now, after a later step
    assert set(vars(got)) == {"qdot", "state", "diagnostics"}


@needs_numba
def test_the_step_behaves_as_the_named_tuple_it_replaces() -> None:
    """Unpacking, indexing, ``len``, ``repr``, ``==``, pickling and copies, ``_asdict`` and
    ``_replace``, read-only fields: as on the object path's step (and the NamedTuple)."""
    ctl, ref, q, meas = _pair()
    got = ctl.step(q, meas, 0.04, qdot_prev=None)
    want = ref.step(q, meas, 0.04, qdot_prev=None)
    qdot, state, diag, secondary, de1_dt, stop, saturated = got
    assert qdot is got.qdot and state is got[1] and diag is got[-5] and len(got) == 7
    assert (secondary, de1_dt, stop, saturated) == (None, None, None, False)
    assert repr(got) == repr(want)
    assert got._fields == want._fields == ControlStep._fields
    assert list(got._asdict()) == list(ControlStep._fields)
    for back in (pickle.loads(pickle.dumps(got)), copy.deepcopy(got)):
        assert type(back) is ControlStep
        _same_step(back, want)
    changed = got._replace(stop="occluded")
    assert changed.stop == "occluded" and changed.qdot is got.qdot
    with pytest.raises(AttributeError):
        got.qdot = np.zeros(6)  # type: ignore[misc]
    assert got == got  # tuple equality: the same objects; equal arrays are ambiguous
    with pytest.raises(ValueError, match="ambiguous"):
        assert got == want


@needs_numba
def test_a_caller_writing_into_its_command_changes_neither_the_history_nor_the_diagnostics() -> (
    None
):
    ctl, ref, q, meas = _pair()
    got = ctl.step(q, meas, 0.04, qdot_prev=None)
    want = ref.step(q, meas, 0.04, qdot_prev=None)
    got.qdot[:] = 9.0
    assert np.all(got.qdot == 9.0)  # the caller's own array, kept
    cmd, ref_cmd = ctl.history._cmds[-1], ref.history._cmds[-1]
    assert cmd.qdot.tobytes() == ref_cmd.qdot.tobytes() == want.qdot.tobytes()
    assert (cmd.t, cmd.q.tobytes()) == (ref_cmd.t, ref_cmd.q.tobytes())
    _same_diag(got.diagnostics, want.diagnostics)


@needs_numba
@pytest.mark.parametrize("first", [True, False])
@pytest.mark.parametrize(
    "change",
    [{"rcond": 0.5, "robust": False}, {"shield": False}, {"scaling": "secondary-first"}],
)
def test_a_law_option_set_after_the_controller_was_built_reaches_its_step(
    first: bool, change: dict[str, Any]
) -> None:
    """On today's main the compiled engine kept the options it packed at construction: a
    command and flags different from the object path's (``rcond = 0.5, robust = False``:
    another command). Now a step sees the change and binds the engine anew (secondary-first
    scaling has none: the step runs the object path and says why)."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    for c in (ctl, ref):
        if not first:
            c.step(q, meas, 0.0, qdot_prev=None)
        for key, value in change.items():
            setattr(c.law, key, value)
    got = ctl.step(q, meas, 0.04, qdot_prev=None)
    want = ref.step(q, meas, 0.04, qdot_prev=None)
    assert got.qdot.tobytes() == want.qdot.tobytes()
    _same_diag(got.diagnostics, want.diagnostics)
    if "scaling" in change:
        assert ctl.engine == "kernels" and "secondary-first" in ctl.engine_reason
    else:
        assert ctl.engine == "compiled" and ctl.engine_reason == ""
        again = ctl.step(q, meas, 0.08, qdot_prev=None)  # the quick path, with the new options
        assert again.qdot.tobytes() == ref.step(q, meas, 0.08, qdot_prev=None).qdot.tobytes()


@needs_numba
@pytest.mark.parametrize("first", [True, False])
@pytest.mark.parametrize("kind", ["bool", "complex", "0-d", "(1, 1)"])
def test_inverse_depths_the_object_path_refuses_get_its_error(first: bool, kind: str) -> None:
    """Boolean inverse depths: the compiled engine took them as 1/m = 1.0 (first step and
    later ones alike) while the object path refuses them. (1, 1) entries: both engines
    stopped with numba's TypingError from the points kernel instead of this ShapeError."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    make = {
        "bool": lambda d: np.ones(1, dtype=bool),
        "complex": lambda d: d.astype(complex),
        "0-d": lambda d: d.reshape(()),
        "(1, 1)": lambda d: d.reshape(1, 1),
    }[kind]
    bad = Measurement(meas.s, tuple(make(d) for d in meas.inv_depth))
    errors = []
    for c in (ctl, ref):
        if not first:
            c.step(q, meas, 0.0, qdot_prev=None)
        with pytest.raises(RedservoError) as info:
            c.step(q, bad, 0.04, qdot_prev=None)
        errors.append((type(info.value), str(info.value), info.value.argument))
    assert errors[0] == errors[1]
    assert errors[0][2] == "inv_depth[0]"


@needs_numba
@pytest.mark.parametrize("kept", ["step", "state", "diagnostics", "nothing"])
def test_the_buffer_is_reused_only_when_nothing_holds_it(kept: str) -> None:
    """The next quick step reuses the last one's buffer (warm in the caches) when its results
    were dropped; a step, a task state or lazy diagnostics kept by the caller hold theirs,
    which then never change, however many steps follow."""
    ctl, ref, q, meas = _pair()
    step = ctl.step(q, meas, 0.04, qdot_prev=None)
    want = ref.step(q, meas, 0.04, qdot_prev=None)
    held = getattr(step, kept) if kept in ("state", "diagnostics") else step
    if kept == "nothing":
        held = None
    first = weakref.ref(ctl._compiled.spare[0])  # no reference of its own
    del step
    other = Measurement(meas.s[::-1].copy(), tuple(2.0 * d for d in meas.inv_depth))
    for k in range(2, 6):
        ctl.step(q, other, 0.04 * k, qdot_prev=None)
    reused = ctl._compiled.spare[0] is first()
    assert reused == (kept == "nothing")
    if kept == "step":
        _same_step(held, want)
    elif kept == "state":
        for a, b in zip(held, want.state, strict=True):
            assert np.asarray(a).tobytes() == np.asarray(b).tobytes()
    elif kept == "diagnostics":
        _same_diag(held, want.diagnostics)


@pytest.mark.parametrize(
    ("name", "value"),
    [("qdot_saturation", np.full(6, 1e-3)), ("feedforward", "known"), ("collision", object())],
)
def test_each_output_option_set_later_is_seen_by_the_quick_steps_one_flag(
    name: str, value: Any
) -> None:
    """The four options the quick step needs unset are read as one flag their setters keep
    (``QuickSetting``); setting one after construction, or unsetting it, flips it."""
    ctl, _, _ = _controller()
    assert ctl._plain_setup
    before = getattr(ctl, name)
    setattr(ctl, name, value)
    assert getattr(ctl, name) is value and not ctl._plain_setup
    setattr(ctl, name, before)
    assert ctl._plain_setup
