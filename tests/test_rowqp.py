"""The compiled dense QP with general rows (redservo.kernels.rowqp) of ``qp``'s distance rows.

Checked against daqp (the library the object path called before) on fuzzed problems: the same
minimiser to 1e-9, the same verdict on infeasible ones, degenerate active sets (duplicated
and dependent rows, a row equal to a bound, a box of zero width) included; a finite
iteration count; a failure is a status, never NaN; the law's relaxed fallback.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from redservo.kernels import rowqp
from redservo.redundancy import distance_rows as distance_rows_module
from redservo.redundancy.distance_rows import ROWS_FAILED, DistanceRows, solve_qp_rows


def _problem(rng: np.random.Generator, law_like: bool) -> tuple[Any, ...]:
    """``(H, f, lo, hi, G, b)``: ``H = JᵀJ + ε I`` (ε relative, 1e-6), ``f`` as the law
    builds it (``−Jᵀẋ − ε z``) or any ``f`` with ``J`` of full column rank; degenerate rows
    on a third of the problems."""
    n = int(rng.integers(1, 9))
    m = int(rng.integers(1, 9)) if law_like else int(rng.integers(n, n + 4))
    r = int(rng.integers(0, 14))
    J = rng.normal(size=(m, n)) * rng.choice([1e-2, 1.0, 1e2])
    eps = 1e-6 * max(np.linalg.norm(J, 2) ** 2, 1e-300)
    H = np.ascontiguousarray(J.T @ J + eps * np.eye(n))
    if law_like:
        f = -(J.T @ rng.normal(size=m)) - eps * rng.normal(size=n)
    else:
        f = rng.normal(size=n) * rng.choice([1e-3, 1.0, 1e3])
    lo, hi = -rng.uniform(0.0, 2.0, n), rng.uniform(0.0, 2.0, n)
    if rng.random() < 0.2:
        j = int(rng.integers(n))
        lo[j] = hi[j]  # a joint fixed (qp's conflicts)
    G, b = rng.normal(size=(r, n)), rng.normal(size=r) * rng.choice([0.1, 1.0])
    if r > 2 and rng.random() < 0.3:
        G[1], b[1] = G[0], b[0]  # a duplicated row
    if r > 3 and rng.random() < 0.3:
        G[2], b[2] = G[0] + G[3], b[0] + b[3] - 0.01  # a dependent row
    if r > 4 and rng.random() < 0.3:
        G[4], b[4] = np.eye(n)[0], lo[0]  # a row equal to a bound
    return H, f, lo, hi, np.ascontiguousarray(G), b


def _daqp(daqp: Any, H: Any, f: Any, lo: Any, hi: Any, G: Any, b: Any) -> tuple[Any, bool]:
    """daqp's minimiser and verdict: scaled to |H| = 1 with tight tolerances (its absolute
    defaults, 1e-6, are looser than the test), its defaults where those fail."""
    s, r = np.abs(H).max(), b.size
    bu, bl = np.concatenate([hi, np.full(r, 1e30)]), np.concatenate([lo, b])
    sense = np.zeros(bu.size, dtype=np.intc)
    tight = {"primal_tol": 1e-14, "dual_tol": 1e-14}
    y, _, flag, _ = daqp.solve(H / s, f / s, G, bu, bl, sense, **tight)
    if flag <= 0:
        y, _, flag, _ = daqp.solve(H, f, G, bu, bl, sense)
    return y, flag > 0


def _violation(lo: Any, hi: Any, G: Any, b: Any, y: Any) -> float:
    worst = max(float(np.max(lo - y)), float(np.max(y - hi)))
    return max(worst, float(np.max(b - G @ y))) if b.size else worst


def test_dense_qp_gives_daqps_minimiser_and_verdict() -> None:
    """2000 problems, half law-like: daqp's minimiser to 1e-9 (relative), every constraint
    met to rounding, the same infeasibility verdict, within the iteration cap."""
    daqp = pytest.importorskip("daqp", reason="daqp is the reference")
    rng = np.random.default_rng(30)
    worst, solved, infeasible = 0.0, 0, 0
    for k in range(2000):
        H, f, lo, hi, G, b = _problem(rng, k % 2 == 0)
        y, status, iterations = rowqp.dense_qp(H, f, lo, hi, G, b)
        ref, feasible = _daqp(daqp, H, f, lo, hi, G, b)
        assert iterations <= 3 * (2 * f.size + b.size) + 10
        assert status == (rowqp.SOLVED if feasible else rowqp.INFEASIBLE), k
        if status == rowqp.SOLVED:
            solved += 1
            assert np.all(np.isfinite(y))
            assert _violation(lo, hi, G, b, y) < 1e-9 * (1.0 + np.max(np.abs(y)))
            worst = max(worst, float(np.max(np.abs(y - ref)) / (1.0 + np.max(np.abs(ref)))))
        else:
            infeasible += 1
    assert worst < 1e-9
    assert solved > 1000 and infeasible > 300


def test_dense_qp_without_rows_is_the_box_qp() -> None:
    """No rows: the compiled box QP's minimiser (tests/test_boxqp.py) to 1e-10."""
    from redservo.kernels import boxqp

    rng = np.random.default_rng(5)
    for _ in range(300):
        H, f, lo, hi, _, _ = _problem(rng, True)
        n = f.size
        y, status, _ = rowqp.dense_qp(H, f, lo, hi, np.zeros((0, n)), np.zeros(0))
        ref, ref_status, _ = boxqp.box_qp(H, f, lo, hi)
        assert status == ref_status == rowqp.SOLVED
        assert np.max(np.abs(y - ref)) <= 1e-10 * (1.0 + np.max(np.abs(ref)))


def test_dense_qp_reports_a_broken_problem_without_nan() -> None:
    """Non-finite data, H not positive definite, a box with lo > hi, the iteration cap: a
    status (FAILED or INFEASIBLE), never an exception; a row asking the impossible within the
    box is INFEASIBLE."""
    H, f = np.eye(2), np.array([1.0, -1.0])
    lo, hi = -np.ones(2), np.ones(2)
    G, b = np.array([[1.0, 1.0]]), np.array([0.5])
    assert rowqp.dense_qp(H, f, lo, hi, G, b)[1] == rowqp.SOLVED
    assert rowqp.dense_qp(H, f, lo, hi, G, np.array([np.nan]))[1] == rowqp.FAILED
    assert rowqp.dense_qp(H, np.array([np.inf, 0.0]), lo, hi, G, b)[1] == rowqp.FAILED
    assert rowqp.dense_qp(-H, f, lo, hi, G, b)[1] == rowqp.FAILED
    assert rowqp.dense_qp(H, f, np.array([2.0, -1.0]), hi, G, b)[1] == rowqp.INFEASIBLE
    assert rowqp.dense_qp(H, f, lo, hi, G, np.array([2.5]))[1] == rowqp.INFEASIBLE
    pairs = np.array([[1.0, 0.0], [-1.0, 0.0]])  # y0 >= 0.5 and y0 <= -0.5
    y, status, _ = rowqp.dense_qp(H, f, lo, hi, pairs, np.array([0.5, 0.5]))
    assert status == rowqp.INFEASIBLE and np.all(np.isfinite(y))


def test_solve_qp_rows_relaxes_then_drops_as_before(monkeypatch: pytest.MonkeyPatch) -> None:
    """The law's rows: the dampers when feasible, else "never closer" (b capped at 0), else
    none (None, said); a solver failure is None with the note qp flags."""
    J, xdot = np.eye(2), np.array([1.0, 0.0])
    lo, hi = -np.ones(2), np.ones(2)
    rows = DistanceRows(np.array([[-1.0, 0.0]]), np.array([-0.2]), ("post",))
    y, note = solve_qp_rows(J, xdot, lo, hi, 1e-6, None, rows)
    assert y is not None and y[0] == pytest.approx(0.2) and "velocity dampers" in note
    push = DistanceRows(np.array([[0.1, 0.0]]), np.array([0.5]), ("post",))  # needs q̇0 = 5
    y, note = solve_qp_rows(J, xdot, lo, hi, 1e-6, None, push)
    assert y is not None and y[0] == pytest.approx(1.0) and "relaxed to 0" in note
    back = DistanceRows(np.array([[-1.0, 0.0]]), np.array([0.1]), ("post",))  # q̇0 <= -0.1
    pushed = np.array([0.5, -1.0])  # a joint pushed off its limit: q̇0 >= 0.5, even relaxed
    y, note = solve_qp_rows(J, xdot, pushed, hi, 1e-6, None, back)
    assert y is None and "infeasible" in note
    failing = SimpleNamespace(
        qp_rows=lambda *a: (np.zeros(2), rowqp.FAILED, False),
        SOLVED=rowqp.SOLVED,
        FAILED=rowqp.FAILED,
    )
    monkeypatch.setattr(distance_rows_module, "_KR", failing)
    y, note = solve_qp_rows(J, xdot, lo, hi, 1e-6, None, rows)
    assert y is None and note.startswith(ROWS_FAILED)


def test_qp_flags_a_failed_row_solve(monkeypatch: pytest.MonkeyPatch) -> None:
    """A failed row solve: the rows dropped for the step, noted, flagged solver-fallback, and
    the command still within its bounds and finite."""
    from redservo import make_law
    from redservo.redundancy import qp as qp_module
    from redservo.redundancy.distance_rows import given_rows
    from redservo.redundancy.flags import Flag
    from redservo.robots import make_robot

    lim = make_robot("panda").limits(0.1)
    n = lim.n
    rng = np.random.default_rng(1)
    J1, e1 = rng.normal(size=(6, n)), rng.normal(0.0, 0.3, 6)
    q = 0.5 * (lim.q_min + lim.q_max)
    rows = DistanceRows(rng.normal(0.0, 0.3, (2, n)), np.array([0.01, -0.02]), ("a", "b"))
    failed = (None, f"{ROWS_FAILED} (numerical failure or iteration cap); 2 rows dropped")
    monkeypatch.setattr(qp_module, "solve_qp_rows", lambda *a: failed)
    law = make_law("qp")
    with given_rows(law, rows):
        res = law(J1=J1, e1=e1, q=q, limits=lim, lam=1.0, dt=0.04, qdot_prev=np.zeros(n))
    assert Flag.SOLVER_FALLBACK in {ev.flag for ev in res.diagnostics.events}
    assert any(i.startswith(ROWS_FAILED) for i in res.diagnostics.info)
    assert np.all(np.isfinite(res.qdot)) and np.all(np.abs(res.qdot) <= lim.qdot_max + 1e-12)
