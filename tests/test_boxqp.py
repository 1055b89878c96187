"""The compiled box-QP solver of the ``qp`` law (redservo.kernels.boxqp) and its use.

Checked against daqp (the reference library) to 1e-9 on fuzzed problems, feasible and not;
the law's default solver, the compiled ``qp`` step and the campaign loop use it, so no
Python solver call is left per step; a failure keeps the ``solver-fallback`` flag.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from redservo import JointLimits, make_law
from redservo.kernels import boxqp
from redservo.redundancy import qp as qp_module
from redservo.redundancy.flags import Flag
from redservo.redundancy.linalg import DEFAULT_RCOND


def _problem(rng: np.random.Generator) -> tuple[Any, ...]:
    """A reduced problem as the law builds it: ``P = JᵀJ + ε I``, ε relative (1e-6)."""
    k, m = int(rng.integers(1, 9)), int(rng.integers(1, 7))
    J = rng.normal(size=(m, k)) * rng.choice([1e-3, 1.0, 1e3])
    eps = 1e-6 * max(np.linalg.norm(J, 2) ** 2, 1e-300)
    P = np.ascontiguousarray(J.T @ J + eps * np.eye(k))
    c = rng.normal(size=k) * rng.choice([1e-3, 1.0, 1e3])
    lo, hi = -rng.uniform(0.0, 2.0, k), rng.uniform(0.0, 2.0, k)
    if rng.random() < 0.3:  # boxes away from 0, as near a limit
        shift = rng.normal(size=k)
        lo, hi = lo + shift, hi + shift
    return P, c, lo, hi


def _kkt_error(P: Any, c: Any, lo: Any, hi: Any, y: Any) -> float:
    """The largest violation of the optimality conditions of the box QP, relative."""
    g = P @ y + c
    scale = 1.0 + np.abs(c) + np.abs(P) @ np.abs(y)
    at_lo, at_hi = y <= lo, y >= hi
    wrong = np.where(at_lo, np.minimum(g, 0.0), np.where(at_hi, np.maximum(g, 0.0), g))
    return float(np.max(np.abs(wrong) / scale))


def test_box_qp_gives_daqps_minimiser_on_fuzzed_problems() -> None:
    """2000 problems: the minimiser of daqp (run on the problem scaled to |P| = 1 and with
    tight tolerances: its absolute defaults, 1e-6, are looser than the test) to 1e-9, inside
    the box exactly, and the optimality conditions to rounding."""
    daqp = pytest.importorskip("daqp", reason="daqp is the reference")
    rng = np.random.default_rng(29)
    worst = 0.0
    for _ in range(2000):
        P, c, lo, hi = _problem(rng)
        y, status, iterations = boxqp.box_qp(P, c, lo, hi)
        assert status == boxqp.SOLVED and iterations <= 10 * c.size + 10
        assert np.all(lo <= y) and np.all(y <= hi)
        assert _kkt_error(P, c, lo, hi, y) < 1e-10
        s, k = np.abs(P).max(), c.size
        tight = {"primal_tol": 1e-14, "dual_tol": 1e-14}
        ref, _, flag, _ = daqp.solve(
            P / s, c / s, np.zeros((0, k)), hi, lo, np.zeros(k, dtype=np.intc), **tight
        )
        assert flag > 0
        worst = max(worst, float(np.max(np.abs(y - ref)) / (1.0 + np.max(np.abs(ref)))))
    assert worst < 1e-9


def test_box_qp_reports_an_infeasible_or_broken_problem() -> None:
    """A box with lo > hi is INFEASIBLE (daqp agrees); non-finite data or a P that is not
    positive definite is FAILED; nothing raises."""
    daqp = pytest.importorskip("daqp", reason="daqp is the reference")
    rng = np.random.default_rng(3)
    for _ in range(200):
        P, c, lo, hi = _problem(rng)
        j = int(rng.integers(c.size))
        lo[j], hi[j] = hi[j] + 0.1, lo[j]
        assert boxqp.box_qp(P, c, lo, hi)[1] == boxqp.INFEASIBLE
        k = c.size
        flag = daqp.solve(P, c, np.zeros((0, k)), hi, lo, np.zeros(k, dtype=np.intc))[2]
        assert flag < 0
    P, c, lo, hi = np.eye(2), np.ones(2), -np.ones(2), np.ones(2)
    assert boxqp.box_qp(P, np.array([np.nan, 1.0]), lo, hi)[1] == boxqp.FAILED
    assert boxqp.box_qp(-P, c, lo, hi)[1] == boxqp.FAILED
    y, status, _ = boxqp.box_qp(np.zeros((0, 0)), np.zeros(0), np.zeros(0), np.zeros(0))
    assert status == boxqp.SOLVED and y.shape == (0,)


def test_polish_rcond_is_the_laws() -> None:
    assert boxqp.POLISH_RCOND == DEFAULT_RCOND


def _active_steps(rng: np.random.Generator, count: int) -> list[dict[str, Any]]:
    """Random steps of a 7-joint arm near its limits with a large error: bounds active."""
    lim = JointLimits(-np.ones(7), np.ones(7), qdot_max=1.0, qddot_max=20.0)
    out = []
    for _ in range(count):
        kw = {
            "J1": rng.normal(size=(int(rng.integers(2, 7)), 7)),
            "q": rng.uniform(-0.98, 0.98, 7),
            "limits": lim,
            "lam": 1.0,
            "dt": 0.04,
            "qdot_prev": rng.uniform(-0.3, 0.3, 7),
        }
        kw["e1"] = 5.0 * rng.normal(size=kw["J1"].shape[0])
        out.append(kw)
    return out


def test_the_default_qp_solver_is_the_compiled_one_and_agrees_with_daqp() -> None:
    """``solver="auto"`` solves in compiled code (the note names it) and gives daqp's command
    to 1e-9 (both polish on the same active set) with the same flags."""
    pytest.importorskip("daqp", reason="daqp is the reference")
    auto, ref = make_law("qp"), make_law("qp", solver="daqp")
    solved = 0
    for kw in _active_steps(np.random.default_rng(5), 300):
        a, b = auto(**kw), ref(**kw)
        if _solver_note(a) == "solver: none (unconstrained optimum within the bounds)":
            continue
        solved += 1
        assert _solver_note(a).startswith("solver: active-set"), a.diagnostics.notes
        assert np.allclose(a.qdot, b.qdot, rtol=1e-9, atol=1e-9)
        assert {e.flag for e in a.diagnostics.events} == {e.flag for e in b.diagnostics.events}
    assert solved > 100


def test_a_failed_compiled_solve_keeps_the_fallback_and_its_flag(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """When the compiled solver reports an infeasible box, the law takes its scipy fallback,
    says so in its notes and raises ``solver-fallback``, as it does when daqp fails."""
    real = qp_module._KB

    def infeasible(*args: Any) -> tuple[Any, ...]:
        out = real.qp_solve_reduced(*args)
        return (*out[:4], boxqp.INFEASIBLE)

    fake = SimpleNamespace(qp_solve_reduced=infeasible, SOLVED=boxqp.SOLVED)
    monkeypatch.setattr(qp_module, "_KB", fake)
    law = make_law("qp")
    kw = next(k for k in _active_steps(np.random.default_rng(8), 50) if _solves(law, k))
    res = law(**kw)
    note = _solver_note(res)
    assert "active-set failed (the bounds do not meet); fallback scipy" in note, note
    assert Flag.SOLVER_FALLBACK in {e.flag for e in res.diagnostics.events}
    assert np.all(np.isfinite(res.qdot)) and np.all(np.abs(res.qdot) <= 1.0 + 1e-12)


def _solver_note(res: Any) -> str:
    return str(next(s for s in res.diagnostics.notes if s.startswith("solver: ")))


def _solves(law: Any, kw: dict[str, Any]) -> bool:
    return not _solver_note(law(**kw)).startswith("solver: none")


def test_the_solver_option_names_the_compiled_solver() -> None:
    assert make_law("qp", solver="active-set")._resolve_backend() == "active-set"
    assert make_law("qp")._resolve_backend() == "active-set"
    with pytest.raises(Exception, match="'active-set'"):
        make_law("qp", solver="no-such-solver")


def _count_law_calls(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Count the ``qp`` law's Python computations (the loop's hand-backs)."""
    calls = [0]
    compute = qp_module.BoundedLeastSquares.compute

    def counted(self: Any, x: Any) -> Any:
        calls[0] += 1
        return compute(self, x)

    monkeypatch.setattr(qp_module.BoundedLeastSquares, "compute", counted)
    return calls


def test_the_campaign_loop_solves_qp_without_python(monkeypatch: pytest.MonkeyPatch) -> None:
    """cm01-gaze sample 1, ``qp``: bounds are active on most steps, none returns to Python, and the
    rows are the object path's bit for bit; with ``solver="daqp"`` the loop hands those
    steps to the law (Python) and the rows are again the object path's."""
    pytest.importorskip("numba", reason="the compiled campaign loop needs numba")
    pytest.importorskip("daqp", reason="daqp is the reference")
    from redservo.campaign import draw_sample, load_campaign
    from redservo.campaign.fastloop import fast_run
    from redservo.experiment.build import build

    d = load_campaign("cm01-gaze")
    exp = build(draw_sample(d, 0, 1).scenario)  # 180 of 227 steps with active bounds
    calls = _count_law_calls(monkeypatch)
    for opts, handed_back in ((None, False), ({"solver": "daqp"}, True)):
        calls[0] = 0
        fast, path = fast_run(exp, "qp", opts)
        assert fast is not None, path
        assert (calls[0] > 10) == handed_back, calls  # daqp: >10 steps with active bounds
        obj = exp.run(method="qp", law_options=opts).summary
        unmeasured = ("min_manipulability", "min_singular_value")  # the loop: None
        same = [{k: v for k, v in x.to_dict().items() if k not in unmeasured} for x in (fast, obj)]
        assert repr(same[0]) == repr(same[1])


def _loop_step(rng: np.random.Generator, lim: Any) -> tuple[Any, ...]:
    """A step's inputs with large errors (bounds active): J1 (m, n) of m = 2, 3 or 6 rows,
    full rank or not, joints near their limits or not, a previous command within the rates."""
    n, m = lim.n, int(rng.choice([2, 3, 6]))
    J1 = rng.normal(size=(m, n))
    if rng.random() < 0.3 and m > 1:
        J1[-1] = J1[0] * rng.uniform(-2, 2)
    e1 = 30.0 * rng.normal(size=m) * 10.0 ** rng.uniform(-3, 0)
    margin = rng.uniform(0.002, 0.15, n) * lim.range
    q = np.where(rng.random(n) < 0.5, lim.q_max - margin, lim.q_min + margin)
    q = np.where(rng.random(n) < 0.5, q, lim.q_min + rng.uniform(0.2, 0.8, n) * lim.range)
    prev = rng.uniform(-0.8, 0.8, n) * lim.qdot_max
    lam, dt = float(rng.choice([0.3, 1.0, 5.0])), float(rng.choice([0.04, 0.08]))
    return np.ascontiguousarray(J1), e1, q, prev, lam, dt


@pytest.mark.parametrize("robot", ["afma6", "panda"])
def test_the_loops_qp_step_is_the_law_objects(robot: str) -> None:
    """The campaign loop's ``qp`` step (kernels/sensed.py ``qp_law``, solver in the kernel) on
    random steps, bounds active on most: the law object's command bit for bit and exactly its
    flags; nothing handed back to Python."""
    pytest.importorskip("numba", reason="the compiled campaign loop needs numba")
    from redservo.campaign.fastloop import _flag_bits, _law_args
    from redservo.kernels.sensed import qp_law
    from redservo.redundancy.packs import limits_pack
    from redservo.robots import make_robot

    rng = np.random.default_rng(11)
    lim = make_robot(robot).limits(0.1)
    lp = limits_pack(lim)
    limits = (lp.rows, lp.has_v, lp.has_a, np.array(lim.q_min), np.array(lim.q_max))
    n, solved, flags = lim.n, 0, set()
    for opts in ({}, {"v_max": 0.3}, {"margin": 0.1, "k_p": 0.5}, {"shield": False}):
        law = make_law("qp", **opts)
        args = _law_args(law, n)
        for _ in range(60):
            J1, e1, q, prev, lam, dt = _loop_step(rng, lim)
            m = e1.shape[0]
            solve = (np.zeros((m, n)), np.zeros(m), np.zeros(n), np.zeros(4, np.int64), e1 * 0)
            sim = (lam, dt, 1e-3, True, np.ones(n), False, False)  # the campaign's types
            qd, bits, need = qp_law(J1, e1, e1, False, q, prev, args, limits, sim, solve)
            res = law(J1=J1, e1=e1, q=q, limits=lim, lam=lam, dt=dt, qdot_prev=prev)
            assert not need
            assert np.array_equal(qd, res.qdot), opts
            assert bits == _flag_bits(res.diagnostics.events), opts
            solved += _solver_note(res).startswith("solver: active-set")
            flags.add(bits)
    assert solved > 100 and len(flags) >= 3
