"""The campaign loop's speed-ups that must not move a bit (issue 29 item 4, docs/scaling.md).

Each shortcut is checked against the computation it replaces: LAPACK without the left
vectors where only ``σ`` and ``V`` are used (the moments' plane), ``wln``'s weighted SVD
skipped when the weights are all 1 (``J1 D`` is ``J1``), the image points measured without
temporaries, the finiteness test without temporary arrays, and the law packed once per
method instead of once per run. Whole campaigns stay bit for bit the object path's
(tests/test_campaign_fast.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("numba", reason="the compiled kernels need numba (redservo[fast])")

from redservo.campaign import load_campaign, looplaw, run_campaign
from redservo.kernels import directional, features, lapack, loop_task, moments, points
from redservo.kernels.linalg import task_svd


def _matrices(rng: Any, count: int) -> list[Any]:
    """Random (m, n) matrices: general, near-planar centred point sets, scaled, rank-deficient."""
    out = []
    for i in range(count):
        m, n = int(rng.integers(1, 16)), int(rng.choice([2, 3, 3, 4, 6, 7]))
        A = rng.normal(size=(m, n))
        if i % 4 == 1 and n == 3:
            noise = rng.normal(size=m) * 10.0 ** rng.integers(-16, -6)
            A[:, 2] = A[:, 0] * rng.normal() + A[:, 1] * rng.normal() + noise
            A -= A.mean(axis=0)
        elif i % 4 == 2:
            A *= 10.0 ** rng.integers(-8, 8)
        elif i % 4 == 3 and m > 1:
            A[1] = A[0]
        out.append(np.ascontiguousarray(A))
    return out


def test_svd_without_left_vectors_gives_the_same_bits() -> None:
    rng = np.random.default_rng(7)
    for A in _matrices(rng, 3000):
        _, s, V, info = lapack.gesvd(A)
        s2, V2, info2 = lapack.gesvd_sv(A)
        assert info == info2 == 0
        assert s.tobytes() == s2.tobytes() and V.tobytes() == V2.tobytes(), A.shape


def test_the_moment_plane_is_the_one_of_the_full_svd() -> None:
    """``fit_plane`` (now without U) against the same formula on scipy's full ``dgesvd``."""
    from scipy.linalg import lapack as scipy_lapack

    rng = np.random.default_rng(3)
    for _ in range(500):
        n = int(rng.integers(4, 12))
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        P = np.c_[rng.normal(size=(n, 2)) * 0.1, np.zeros(n)] @ R.T + [0.01, -0.02, 0.6]
        plane, code, _ = moments.fit_plane(P)
        Q = P - P.sum(axis=0) / n
        _, _, Vt, _ = scipy_lapack.dgesvd(np.ascontiguousarray(Q))
        c = P.sum(axis=0) / n
        d = Vt[2, 0] * c[0] + Vt[2, 1] * c[1] + Vt[2, 2] * c[2]
        if code == moments.OK:
            assert plane.tobytes() == (Vt[2] / d).tobytes()


def test_wln_reuses_the_task_svd_when_no_joint_is_weighted() -> None:
    assert directional._all_ones(np.ones(7))
    assert not directional._all_ones(np.array([1.0, 1.0, np.nextafter(1.0, 0.0)]))
    rng = np.random.default_rng(1)
    J1 = rng.normal(size=(6, 7))
    JD = J1 * np.ones(7)  # what wln builds when every weight is 1
    a, b = task_svd(J1, 1e-8, 0.0), task_svd(JD, 1e-8, 0.0)
    for x, y in zip(a, b, strict=True):
        assert np.asarray(x).tobytes() == np.asarray(y).tobytes()


def test_points_measured_without_temporaries_are_points_measure() -> None:
    rng = np.random.default_rng(5)
    for _ in range(200):
        cMo = np.eye(4)
        cMo[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        cMo[:3, 3] = rng.normal(size=3) * 0.1 + [0.0, 0.0, 0.5]
        pts = rng.normal(size=(3, 3)) * 0.1
        s, iz, bad = features.points_measure(cMo, pts)
        for k in range(3):
            X, Y, Z = points.camera_point(cMo, pts, k)
            assert (X / Z, Y / Z, 1.0 / Z) == (s[2 * k], s[2 * k + 1], iz[k]) or bad >= 0
        L = np.empty((6, 6))
        for k in range(3):
            points.point_interaction_into(s[2 * k], s[2 * k + 1], iz[k], L, 2 * k)
        assert L.tobytes() == features.points_interaction(s, iz).tobytes()
        assert L[:2].tobytes() == features.point_interaction(s[0], s[1], iz[0]).tobytes()


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_the_finiteness_test_of_the_loop(bad: float) -> None:
    J1, e1 = np.ones((2, 3)), np.ones(2)
    assert loop_task.all_finite(J1, e1)
    for where in ("J1", "e1"):
        J, e = J1.copy(), e1.copy()
        if where == "J1":
            J[1, 2] = bad
        else:
            e[1] = bad
        assert not loop_task.all_finite(J, e)


def test_a_law_is_packed_once_per_method_not_per_run(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[str] = []
    real = looplaw.law_args

    def counted(law: Any, n: int) -> Any:
        calls.append(law.name)
        return real(law, n)

    monkeypatch.setattr(looplaw, "law_args", counted)
    monkeypatch.setattr(looplaw._LAWS, "laws", {}, raising=False)
    res = run_campaign(
        load_campaign("cm01-gaze"),
        samples=3,
        methods=["classical", "wln"],
        workers=1,
        progress=False,
    )
    assert len(res.rows) == 6
    assert sorted(calls) == ["classical", "wln"]
