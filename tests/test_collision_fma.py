"""The written-out 3-vector products (kernels/fma.py) give the BLAS's bits, and the fused
multiply-add of the reference path rounds once, as the hardware's does."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.kernels._jit import COMPILED, kernel
from redservo.kernels.collide import _gap
from redservo.kernels.fma import _fma_exact, dot3, fma, rtw3, sq3
from redservo.spatial import make_transform


@kernel
def _mismatches(Rs: Any, ws: Any) -> Any:
    """Values where dot3/sq3/rtw3 differ from np.dot / R.T @ w (compared as bits)."""
    bad_dot = bad_mv = 0
    for k in range(Rs.shape[0]):
        ref = Rs[k].T @ ws[k]
        w0, w1, w2 = ws[k, 0], ws[k, 1], ws[k, 2]
        local = rtw3(Rs[k], w0, w1, w2)
        for i in range(3):
            if local[i] != ref[i] or np.signbit(local[i]) != np.signbit(ref[i]):
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


@pytest.mark.skipif(not COMPILED, reason="the compiled chains (plain Python: numpy's own products)")
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


@kernel
def _gap_blas(x: float, a0: Any, ab: Any, R: Any, t: Any, size: Any, cylinder: bool) -> float:
    """The search's objective as it was written before kernels/fma.py: numpy's products."""
    w = (a0 + x * ab) - t
    local = R.T @ w
    v = np.zeros(3)
    if cylinder:
        radius, h = size[0], 0.5 * size[1]
        rho = np.sqrt(local[0] * local[0] + local[1] * local[1])
        dr, dz = rho - radius, abs(local[2]) - h
        if dr <= 0.0 and dz <= 0.0:
            return dz if dz >= dr else dr
        if dr > 0.0:
            v[0] = local[0] - local[0] * (radius / rho)
            v[1] = local[1] - local[1] * (radius / rho)
        if dz > 0.0:
            v[2] = local[2] - (h if local[2] >= 0.0 else -h)
        return np.sqrt(np.dot(v, v))
    if np.all(np.abs(local) <= size):
        return -np.min(size - np.abs(local))
    for k in range(3):
        v[k] = local[k] - min(max(local[k], -size[k]), size[k])
    return np.sqrt(np.dot(v, v))


@pytest.mark.skipif(not COMPILED, reason="compares compiled products")
def test_the_search_objective_is_the_blas_forms_to_the_bit() -> None:
    rng = np.random.default_rng(2)
    seen_inside = 0
    for i in range(20_000):
        M = make_transform(rotvec=rng.normal(0.0, 1.0, 3), t=rng.normal(0.0, 0.3, 3))
        R, t = np.ascontiguousarray(M[:3, :3]), np.ascontiguousarray(M[:3, 3])
        a0 = rng.normal(0.0, 0.3, 3)
        ab = rng.normal(0.0, 0.3, 3)
        cylinder = i % 2 == 0
        size = np.array([rng.uniform(0.01, 0.2), rng.uniform(0.1, 1.0), 0.0])
        if not cylinder:
            size = rng.uniform(0.01, 0.3, 3)
        x = rng.uniform(0.0, 1.0)
        got = _gap(x, a0, ab, R, t, size, cylinder)
        assert got == _gap_blas(x, a0, ab, R, t, size, cylinder)
        seen_inside += got < 0.0
    assert seen_inside > 100  # both branches of both solids
