"""A kernel called by another kernel with constants is compiled once for the plain types
(redservo.kernels._jit._plain_calls), not once per constant (numba's literal types)."""

from __future__ import annotations

import pytest

from redservo.kernels import _jit

pytestmark = pytest.mark.skipif(not _jit.COMPILED, reason="numba is off: nothing compiles")


def test_constants_at_call_sites_share_one_compilation() -> None:
    import numba

    @numba.njit(cache=False)
    def scale(x: float, k: int, flag: bool) -> float:
        return x * k if flag else -x

    _jit._plain_calls(scale)

    @numba.njit(cache=False)
    def caller(x: float) -> float:
        return scale(x, 2, True) + scale(x, 3, False) + scale(x, 7, True)

    assert caller(1.5) == 1.5 * 2 - 1.5 + 1.5 * 7  # the same numbers
    assert [str(s) for s in scale.signatures] == ["(float64, int64, bool)"]


def test_every_kernel_gets_plain_calls() -> None:
    def f(x: float) -> float:
        return x

    compiled = _jit.kernel(f)
    patched = vars(compiled).get("get_call_template")
    assert patched is not None and patched.__qualname__.startswith("_plain_calls.")
