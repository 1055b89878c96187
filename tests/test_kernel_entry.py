"""The hot paths call a kernel's compiled version at its entry point once its argument types
are known (redservo.kernels.entry): Controller.step's compiled engine and a law call with the
signature seen just before, with the same numbers bit for bit; any other argument goes
through numba's dispatcher as before."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import redservo.redundancy.kernel_call as kc
from redservo import make_law
from redservo.binding.control import CompiledControl
from redservo.kernels import compiled
from redservo.kernels.entry import entry_of, plain
from tests.test_public_path_speed import LAWS, _controller, _inputs, _same, _same_diag

needs_numba = pytest.mark.skipif(not compiled(), reason="entry points are numba's")


def _refuse(*_: Any, **__: Any) -> Any:
    raise AssertionError("the dispatcher was called")


def test_plain_is_the_type_numba_gives_the_kernels_arrays() -> None:
    a = np.zeros(3)
    assert plain(a)
    assert not plain(np.zeros(3, dtype=np.float32))
    assert not plain(np.zeros((3, 1)))
    assert not plain(np.zeros(6)[::2])
    ro = np.zeros(3)
    ro.setflags(write=False)
    assert not plain(ro)
    assert not plain([0.0, 0.0])


def test_a_function_that_is_not_a_numba_dispatcher_has_no_entry() -> None:
    assert entry_of(lambda x: x, (np.zeros(2),)) is None


@needs_numba
def test_an_entry_is_found_only_for_types_already_compiled() -> None:
    from redservo.kernels.control import control_layout
    from redservo.kernels.joint_check import joints_inside

    a, lo, hi = np.zeros(3), -np.ones(3), np.ones(3)
    assert joints_inside(a, lo, hi, True)
    entry = entry_of(joints_inside, (a, lo, hi, True))
    assert callable(entry) and entry(a, lo, hi, True) is True
    assert entry_of(joints_inside, (a.astype(np.float32), lo, hi, True)) is None  # not compiled
    assert entry_of(control_layout, (1, 2, 3)) is None  # not a dispatcher


@needs_numba
@pytest.mark.parametrize("prev", [False, True])
def test_the_controller_calls_its_kernel_at_its_entry_with_the_same_numbers(
    prev: bool,
) -> None:
    """After the first step the dispatcher is no longer called (on today's main every step
    goes through it), and every step is bit for bit the object path's."""
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    eng = ctl._compiled
    assert eng is not None
    qdot = np.zeros(q.shape[0]) if prev else None
    for k in range(3):
        got = ctl.step(q, meas, 0.04 * k, qdot_prev=qdot)
        want = ref.step(q, meas, 0.04 * k, qdot_prev=qdot)
        assert got.qdot.tobytes() == want.qdot.tobytes()
        _same_diag(got.diagnostics, want.diagnostics)
        for a, b in zip(got.state, want.state, strict=True):
            assert np.asarray(a).tobytes() == np.asarray(b).tobytes()
        if k == 0:
            assert eng.entry[0] is not None
            object.__setattr__(eng, "kernel", _refuse)
        qdot = got.qdot if prev else None


@needs_numba
def test_an_argument_of_another_type_goes_through_the_dispatcher(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A read-only ``qdot_prev`` (numba types it apart) is not given to the entry found for
    writeable arrays: the step copies it (the kernel only reads it; one compiled version
    serves both, tests/test_warmup_types.py), and the entry gets the writeable copy."""
    ctl, q, meas = _controller()
    seen: list[tuple[bool, bool]] = []
    run = CompiledControl.run_kernel

    def spy(self: CompiledControl, q: Any, packs: Any, plain: bool = False) -> Any:
        prev = packs[4][2]
        seen.append((plain, prev.flags.writeable and prev.flags.c_contiguous))
        return run(self, q, packs, plain)

    monkeypatch.setattr(CompiledControl, "run_kernel", spy)
    prev = np.zeros(q.shape[0])
    first = ctl.step(q, meas, 0.0, qdot_prev=prev)
    prev.setflags(write=False)
    second = ctl.step(q, meas, 0.04, qdot_prev=prev)
    assert seen == [(True, True), (True, True)]
    assert first.qdot.tobytes() == second.qdot.tobytes()


@needs_numba
@pytest.mark.parametrize("method", ["classical", "iterative-smooth", "directional"])
def test_a_law_call_with_the_signature_seen_calls_the_kernel_at_its_entry(
    method: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The second call with the same signature finds the entry, the third calls it (the
    dispatcher refused), bit for bit a fresh law's result."""
    law = make_law(method)
    kw = _inputs(1, True)
    law(**kw)
    law(**kw)
    assert law.__dict__["_kernel_seen"].entry[0] is not None

    class Refusing:
        law_into = staticmethod(_refuse)

    monkeypatch.setattr(kc, "_KC", Refusing)
    for qdot_prev in (kw["qdot_prev"], None):  # new arrays, the same limits object
        fresh = {k: v.copy() if isinstance(v, np.ndarray) else v for k, v in kw.items()}
        fresh["qdot_prev"] = qdot_prev
        got = law(**fresh)
        monkeypatch.undo()
        _same(got, make_law(method)(**fresh))
        monkeypatch.setattr(kc, "_KC", Refusing)


def test_only_writeable_aligned_arrays_take_the_law_calls_entry() -> None:
    a = np.zeros(4)
    assert kc._plain(a, (4,))
    ro = a.copy()
    ro.setflags(write=False)
    assert not kc._plain(ro, (4,))
    assert not kc._plain(a, (3,))


def test_a_kernel_without_an_entry_is_looked_up_once_and_runs_through_its_dispatcher(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """No entry (numba off, or types it has no version for): one look-up, then the
    dispatcher (or the plain function) at every step, with the same numbers."""
    import redservo.binding.control as bc

    looked: list[int] = []

    def none(*_: Any) -> None:
        looked.append(1)

    monkeypatch.setattr(bc, "entry_of", none)
    ctl, q, meas = _controller()
    ref, _, _ = _controller(engine="python")
    for k in range(3):
        got, want = (c.step(q, meas, 0.04 * k, qdot_prev=None) for c in (ctl, ref))
        assert got.qdot.tobytes() == want.qdot.tobytes()
    assert ctl._compiled is not None and ctl._compiled.entry[0] is False
    assert looked == [1]


@needs_numba
@pytest.mark.parametrize("method", LAWS)
def test_repeated_calls_at_the_entry_equal_a_fresh_laws_on_new_values(
    method: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Same limits object and shapes, new values at every call (joints near their limits,
    rate limits: the safety layer's events), the dispatcher refused once the entry is found:
    command and diagnostics bit for bit those of a fresh law on the full path."""
    rng = np.random.default_rng(7)
    kw = _inputs(3, True)
    m, n = kw["J1"].shape
    law = make_law(method)
    law(**kw)
    law(**kw)  # the entry is found here

    class Refusing:
        law_into = staticmethod(_refuse)

    for _ in range(20):
        kw = {
            **kw,
            "J1": rng.normal(size=(m, n)),
            "e1": 5.0 * rng.normal(size=m),
            "q": rng.uniform(-0.99, 0.99, n),
            "qdot_prev": rng.uniform(-0.3, 0.3, n) if rng.random() < 0.7 else None,
        }
        monkeypatch.setattr(kc, "_KC", Refusing)
        got = law(**kw)
        monkeypatch.undo()
        _same(got, make_law(method)(**kw))
