"""A law call hands the step kernel one array type (C-contiguous, aligned, writeable float64)
whatever the caller's arrays: numba compiles a kernel once per argument type, and a read-only
input (an array a result or a JointLimits hands out, ``setflags(write=False)``) compiled the
whole law chain a second time (20 compilations, 26 s of ``make test``'s tests)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

import redservo.redundancy.kernel_call as kc
from redservo import JointLimits, make_law

NAMES = ("J1", "e1", "q", "qdot_prev")


def _inputs() -> dict[str, Any]:
    rng = np.random.default_rng(3)
    return {
        "J1": rng.normal(size=(6, 7)),
        "e1": rng.normal(size=6),
        "q": rng.uniform(-0.5, 0.5, 7),
        "qdot_prev": rng.normal(0.0, 0.1, 7),
    }


def _spy(monkeypatch: pytest.MonkeyPatch) -> list[tuple[Any, ...]]:
    """Record the arguments of every call of the law kernel (``law_into``)."""
    calls: list[tuple[Any, ...]] = []
    real = kc._KC

    def law_into(*args: Any) -> Any:
        calls.append(args)
        return real.law_into(*args)

    monkeypatch.setattr(
        kc, "_KC", SimpleNamespace(law_into=law_into, control_layout=real.control_layout)
    )
    return calls


def _arrays(args: tuple[Any, ...]) -> list[Any]:
    q, J1, e1, _, _, _, inputs, buf = args
    return [q, J1, e1, *inputs, buf]


@pytest.mark.parametrize("name", NAMES)
def test_a_read_only_input_reaches_the_kernel_as_a_writeable_array_with_the_same_bits(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    lim = JointLimits(-np.ones(7), np.ones(7), qdot_max=1.0, qddot_max=5.0)
    want = make_law("classical")(limits=lim, lam=0.5, dt=0.04, **_inputs())
    calls = _spy(monkeypatch)
    x = _inputs()
    x[name].setflags(write=False)
    got = make_law("classical")(limits=lim, lam=0.5, dt=0.04, **x)
    assert calls, "the law kernel was not called"
    for a in _arrays(calls[-1]):
        assert a.flags.carray, "a kernel argument that numba types apart from the warmed one"
    assert got.qdot.tobytes() == want.qdot.tobytes()
    assert got.diagnostics.flags == want.diagnostics.flags
    assert not x[name].flags.writeable  # the caller's array is left as it was
