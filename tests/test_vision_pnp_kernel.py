"""The PnP pose's check in one compiled call (kernels/pnp_rms.py) is numpy's bit for bit:
the same poses refused (not finite, a point behind) and the same RMS reprojection error, for
4 to 128 points (issue 28, image campaigns' speed)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("cv2", reason="the PnP pose needs redservo[vision]")

from redservo.kernels import compiled
from redservo.vision import pnp


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _case(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (n, 3), their noisy pixels (n, 2) and a pose (4, 4): mostly in front, some
    with a point behind or at the 1e-6 m limit, some not finite."""
    P = rng.uniform(-0.1, 0.1, (n, 3)) * 10.0 ** rng.uniform(-3, 0)
    T = np.eye(4)
    T[:3, :3] = _rotation(rng)
    T[:3, 3] = [*rng.uniform(-0.2, 0.2, 2), rng.uniform(0.05, 2.0)]
    kind = rng.integers(0, 10)
    if kind == 0:
        T[2, 3] = -T[2, 3]  # behind
    elif kind == 1:
        T[rng.integers(0, 3), rng.integers(0, 4)] = rng.choice([np.nan, np.inf, -np.inf])
    elif kind == 2:  # a point exactly at the limit
        Pc0 = P[0] @ T[:3, :3].T
        T[2, 3] = 1e-6 - Pc0[2]
    Pc = P @ T[:3, :3].T + T[:3, 3]
    with np.errstate(all="ignore"):
        uv = Pc[:, :2] / Pc[:, 2:3] * 600.0 + [320.0, 240.0]
    uv = np.nan_to_num(uv) + rng.normal(0.0, 10.0 ** rng.uniform(-6, 1), uv.shape)
    return np.ascontiguousarray(P), np.ascontiguousarray(uv), T


@pytest.mark.skipif(not compiled(), reason="the compiled path needs numba")
@pytest.mark.parametrize("n", [4, 5, 7, 8, 9, 16, 23, 128])
def test_the_pose_check_is_numpys_bit_for_bit(monkeypatch: pytest.MonkeyPatch, n: int) -> None:
    rng = np.random.default_rng(n)
    K = pnp._intrinsics(pnp._DEFAULT_CAMERA)
    cases = [_case(rng, n) for _ in range(300)]
    fast = [pnp._checked(P, uv, K, T) for P, uv, T in cases]
    monkeypatch.setattr(pnp, "_MAX_COMPILED", -1)  # the numpy code
    slow = [pnp._checked(P, uv, K, T) for P, uv, T in cases]
    for a, b in zip(fast, slow):
        assert (a is None) == (b is None)
        if a is not None and b is not None:
            assert a.cMo is b.cMo
            assert type(a.rms_px) is float and a.rms_px.hex() == b.rms_px.hex()
    refused = sum(a is None for a in fast)
    assert 0 < refused < len(cases) // 2  # both branches fuzzed


def test_more_points_than_the_kernel_sums_are_checked_by_numpy() -> None:
    rng = np.random.default_rng(7)
    P, uv, T = _case(rng, 129)
    T = np.eye(4)
    T[2, 3] = 1.0
    got = pnp._checked(P, uv, pnp._intrinsics(pnp._DEFAULT_CAMERA), T)
    Pc = P + np.array([0.0, 0.0, 1.0])
    proj = Pc[:, :2] / Pc[:, 2:3] * 600.0 + [320.0, 240.0]
    assert got is not None
    assert got.rms_px == float(np.sqrt(np.mean(np.sum((proj - uv) ** 2, axis=1))))
