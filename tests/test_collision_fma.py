"""The written-out 3-vector products (kernels/fma.py) give the BLAS's bits, and the fused
multiply-add of the reference path rounds once, as the hardware's does."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.kernels._jit import COMPILED, kernel
from redservo.kernels.fma import _fma_exact, dot3, fma, rtw3, sq3


@kernel
def _mismatches(Rs: Any, ws: Any) -> Any:
    """Values where dot3/sq3/rtw3 differ from np.dot / R.T @ w (compared as bits)."""
    bad_dot = bad_mv = 0
    for k in range(Rs.shape[0]):
        ref = Rs[k].T @ ws[k]
        w0, w1, w2 = ws[k, 0], ws[k, 1], ws[k, 2]
        for i in range(3):
            got = rtw3(Rs[k], i, w0, w1, w2)
            if got != ref[i] or np.signbit(got) != np.signbit(ref[i]):
                bad_mv += 1
        d, e = sq3(w0, w1, w2), np.dot(ws[k], ws[k])
        if d != e or dot3(ws[k], ws[k]) != e:
            bad_dot += 1
        if dot3(Rs[k, 0], ws[k]) != np.dot(Rs[k, 0], ws[k]):
            bad_dot += 1
    return bad_dot, bad_mv


def _cases(n: int, seed: int) -> tuple[Any, Any]:
    rng = np.random.default_rng(seed)
    R = rng.normal(size=(n, 3, 3)) * rng.uniform(0.0, 3.0, (n, 1, 1))
    w = rng.normal(size=(n, 3)) * rng.uniform(0.0, 2.0, (n, 1))
    w[: n // 10, rng.integers(0, 3)] = 0.0  # zeros and signed zeros
    w[n // 10 : n // 5, 0] = -0.0
    return R, w


@pytest.mark.skipif(not COMPILED, reason="the compiled chains (the reference path is slow)")
def test_the_written_out_products_are_the_blas_bits_on_a_million_cases() -> None:
    R, w = _cases(1_000_000, 0)
    assert _mismatches(R, w) == (0, 0)


def test_the_reference_path_gives_the_same_bits_as_the_compiled_one() -> None:
    rng = np.random.default_rng(1)
    abc = rng.normal(size=(2000, 3)) * 10.0 ** rng.integers(-8, 4, (2000, 3))
    abc[:20, 2] = -abc[:20, 0] * abc[:20, 1]  # exact cancellations
    for a, b, c in abc:
        got = fma(a, b, c)
        assert got == _fma_exact(a, b, c)
        assert np.signbit(got) == np.signbit(_fma_exact(a, b, c))


def test_the_fused_multiply_add_rounds_once() -> None:
    e = 2.0**-30
    a, b = 1.0 + e, 1.0 - e  # a b = 1 - 2^-60: the plain product rounds to 1
    assert a * b - 1.0 == 0.0
    assert fma(a, b, -1.0) == -(2.0**-60) == _fma_exact(a, b, -1.0)
    assert np.signbit(_fma_exact(-0.0, 1.0, -0.0)) and not np.signbit(_fma_exact(-0.0, 1.0, 0.0))
    assert np.isnan(_fma_exact(np.inf, 0.0, 1.0)) and _fma_exact(np.inf, 2.0, 1.0) == np.inf
