"""The dots' predicted image motion in compiled calls (kernels/dot_shift.py) is the numpy
code's bit for bit: point and moment depths, dots without a depth, with a NaN pixel, behind
the new camera, every number of dots (issue 28, image campaigns' speed)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from redservo.camera import Camera
from redservo.kernels import compiled
from redservo.vision import motion
from redservo.vision.optics import Optics


def _pose(rng: np.random.Generator, big: bool) -> np.ndarray:
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    R = q if np.linalg.det(q) > 0 else -q
    if not big:  # a small motion: the rotation's log scaled down
        w = rng.normal(0.0, 0.05, 3)
        K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        R = np.eye(3) + K + 0.5 * K @ K
        R, _ = np.linalg.qr(R)
        R = R * np.sign(np.diag(_))
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = rng.normal(0.0, 0.3 if big else 0.02, 3)
    return T


def _case(rng: np.random.Generator, n: int) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    uv = rng.uniform(-50.0, 700.0, (n, 2))
    if rng.random() < 0.3:
        uv[rng.integers(0, n), rng.integers(0, 2)] = np.nan
    terms = []
    split = int(rng.integers(0, n + 1))
    for dots, kind in ((np.arange(split), "point"), (np.arange(split, n), "moments")):
        if kind == "point":
            for j in dots:
                rho = rng.choice(
                    [rng.uniform(0.2, 5.0), 0.0, -1.0, np.nan], p=[0.85, 0.05, 0.05, 0.05]
                )
                terms.append(SimpleNamespace(inv_depth=(rho,), dots=np.array([j]), kind=kind))
        elif dots.size:
            plane = (rng.normal(0.0, 0.5), rng.normal(0.0, 0.5), rng.uniform(-0.5, 3.0))
            terms.append(SimpleNamespace(inv_depth=plane, dots=dots, kind=kind))
    if rng.random() < 0.2:
        terms.append(SimpleNamespace(inv_depth=None, dots=np.arange(n), kind="point"))
    bMc = _pose(rng, big=True)
    bMc_prev = bMc @ _pose(rng, big=rng.random() < 0.3)
    return terms, uv, bMc_prev, bMc


@pytest.mark.skipif(not compiled(), reason="the compiled path needs numba")
@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 8, 13])
def test_the_predicted_shift_is_the_numpy_codes_bit_for_bit(
    monkeypatch: pytest.MonkeyPatch, n: int
) -> None:
    rng = np.random.default_rng(n)
    optics = Optics(Camera())
    cases = [_case(rng, n) for _ in range(300)]
    fast = [motion.camera_shift(t, optics, uv, a, b) for t, uv, a, b in cases]
    monkeypatch.setattr(motion, "compiled", lambda: False)
    slow = [motion.camera_shift(t, optics, uv, a, b) for t, uv, a, b in cases]
    nan_rows = 0
    for a, b in zip(fast, slow):
        assert a is not None and b is not None
        assert a.shape == b.shape == (n, 2) and a.dtype == b.dtype
        assert a.tobytes() == b.tobytes()
        nan_rows += int(np.isnan(a).any(axis=1).sum())
    assert 0 < nan_rows < n * len(cases) // 2  # both kinds of rows fuzzed


def test_a_camera_with_distortion_keeps_the_numpy_code(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(3)
    optics = Optics(Camera(), k1=-0.1)
    terms, uv, a, b = _case(rng, 4)
    called = []
    real = motion.predicted_shift
    monkeypatch.setattr(motion, "predicted_shift", lambda *x: called.append(1) or real(*x))
    motion.camera_shift(terms, optics, uv, a, b)
    assert called == [1]
