"""The camera-motion limit's fastest image point in one compiled call
(``kernels/image_motion.fastest_point``, issue 28, item 6): the speed of the numpy code it
replaces bit for bit on fuzzed interaction matrices, Jacobians and commands (NaN where that
code gives NaN), and that code's own answer for rows it cannot take."""

from __future__ import annotations

import math

import numpy as np
import pytest

from redservo.control import image_motion
from redservo.control.image_motion import ImageMotionLimit, image_motion_scale


def _numpy_speed(L: np.ndarray, J: np.ndarray, qdot: np.ndarray, rows: np.ndarray) -> float:
    """The code the kernel replaced."""
    with np.errstate(invalid="ignore", over="ignore"):
        sdot = L @ (J @ qdot)
    r = np.asarray(rows, dtype=np.intp)
    return float(np.max(np.hypot(sdot[r], sdot[r + 1])))


@pytest.mark.parametrize("seed", range(8))
def test_the_fastest_point_is_the_numpy_codes_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    limit = ImageMotionLimit(0.02, 1 / 30)
    for i in range(500):
        k, n = 2 * int(rng.integers(1, 7)), int(rng.integers(2, 9))
        L = rng.normal(size=(k, 6)) * 10.0 ** rng.uniform(-3, 3)
        J = rng.normal(size=(6, n))
        qdot = rng.normal(size=n) * 10.0 ** rng.uniform(-8, 3)
        if i % 41 == 0:
            qdot[0] = np.nan
        elif i % 43 == 0:
            qdot[-1] = np.inf
        order = rng.permutation(k // 2)[: int(rng.integers(1, k // 2 + 1))]
        rows = (2 * order).astype(np.int64)
        want = _numpy_speed(L, J, qdot, rows)
        got = image_motion_scale(L, J, qdot, rows, limit)
        if math.isnan(want):
            assert got[0] == 1.0 and math.isnan(got[1])
        else:
            assert np.float64(got[1]).tobytes() == np.float64(want).tobytes()
            sigma = 1.0 if want <= limit.max_speed else limit.max_speed / want
            assert got == (sigma, want) or (math.isinf(want) and got[0] == 1.0)


def test_rows_the_kernel_cannot_take_get_the_numpy_codes_answer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A negative row (numpy counts from the end) or one past ``L`` (numpy's IndexError),
    and arrays that are not C-contiguous float64, take the numpy code."""
    rng = np.random.default_rng(3)
    L, J, qdot = rng.normal(size=(8, 6)), rng.normal(size=(6, 7)), rng.normal(size=7)
    limit = ImageMotionLimit(0.02, 1 / 30)
    neg = np.array([-2, 0], dtype=np.int64)
    assert image_motion_scale(L, J, qdot, neg, limit)[1] == _numpy_speed(L, J, qdot, neg)
    with pytest.raises(IndexError):
        image_motion_scale(L, J, qdot, np.array([7], dtype=np.int64), limit)
    calls = []
    monkeypatch.setattr(image_motion, "_K", type("K", (), {"fastest_point": calls.append}))
    rows = np.array([0, 2], dtype=np.int64)
    got = image_motion_scale(np.asfortranarray(L), J, qdot, rows, limit)
    assert got[1] == _numpy_speed(L, J, qdot, rows) and not calls
