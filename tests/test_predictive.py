"""The predictive law (redservo.redundancy.predictive, docs/predictive.md): its plan respects
the limits and the visibility over the horizon, the warm start reuses the previous plan, an
infeasible horizon or a solver limit is flagged and falls back to the qp law, and a Panda
start where every reactive law fails is solved."""

from __future__ import annotations

import numpy as np
import pytest

from redservo import Flag, JointLimits, make_law
from redservo.campaign.definition import load_campaign
from redservo.campaign.fastloop import fast_run
from redservo.campaign.sampling import draw_sample
from redservo.experiment.build import build
from redservo.redundancy.predictive_model import horizon, point_prediction
from redservo.scenario import load_scenario

LIM = JointLimits(
    np.full(6, -1.0),
    np.full(6, 1.0),
    qdot_max=np.full(6, 0.8),
    qddot_max=np.full(6, 4.0),
)
DT = 0.04


def _problem(rng: np.random.Generator) -> dict[str, object]:
    J1 = rng.normal(size=(4, 6))
    return {
        "J1": J1,
        "e1": rng.normal(scale=0.5, size=4),
        "q": rng.uniform(-0.95, 0.95, 6),
        "limits": LIM,
        "lam": 0.5,
        "dt": DT,
        "qdot_prev": rng.uniform(-0.3, 0.3, 6),
    }


def _positions(law, q0: np.ndarray) -> np.ndarray:
    """The planned joint positions q_1..q_N of the law's last plan."""
    hz = horizon(law.horizon, law.control_horizon)
    return q0 + DT * (hz.M @ law.last_plan)


def test_plan_respects_every_limit_over_the_horizon() -> None:
    """Random local-model problems: each planned block within the velocity limits, the steps
    between blocks (and from q̇_prev) within q̈_max dt, every planned position within the
    limits less the margin (or no deeper than the start), and the command is the first block."""
    rng = np.random.default_rng(3)
    law = make_law("predictive", margin=0.05)
    band = 0.05 * 2.0
    planned = 0
    for _ in range(60):
        kw = _problem(rng)
        law.reset()
        res = law(**kw)  # type: ignore[arg-type]
        assert np.all(np.isfinite(res.qdot))
        assert np.all(np.abs(res.qdot) <= LIM.qdot_max + 1e-12)
        if law.last_plan is None:  # fell back: the flags say so
            assert res.diagnostics.has(Flag.SOLVER_FALLBACK)
            continue
        planned += 1
        U, q0, prev = law.last_plan, kw["q"], kw["qdot_prev"]
        assert np.all(np.abs(U) <= LIM.qdot_max + 1e-9)
        steps = np.diff(np.vstack([prev, U]), axis=0)
        assert np.all(np.abs(steps) <= LIM.qddot_max * DT + 1e-7)
        Q = _positions(law, q0)
        lo = np.minimum(LIM.q_min + band, q0) - 1e-7
        hi = np.maximum(LIM.q_max - band, q0) + 1e-7
        assert np.all(Q >= lo) and np.all(Q <= hi)
        assert np.allclose(res.qdot, U[0], atol=1e-9) or res.diagnostics.events
    assert planned >= 40


def _panda_state():
    exp = build(load_scenario("panda-4points"))
    bMc, J = exp.robot.kinematics(exp.q0, check_limits=False)
    state = exp.task.evaluate(exp.scene, bMc, J, 0.0)
    return exp, state


def test_plan_keeps_the_points_in_the_image() -> None:
    """Global model on the Panda: the planned image points at every period stay inside the
    image less the pixel margin, or no deeper in the band than the measured points already
    are (the law relaxes the bound of a point that starts inside the band), for the
    nonlinear prediction of the plan, within 1 px (five SQP iterations; one iteration keeps
    the linearised constraint, the nonlinear prediction then comes ~10 px closer at the end
    of the horizon), and the global model was used."""
    exp, state = _panda_state()
    law = make_law("predictive", image_margin_px=60.0, sqp_iterations=5)
    q, prev = exp.q0, np.zeros(exp.robot.n)
    cam = exp.camera
    for _ in range(5):  # a few periods, each planned from the previous
        law.observe(exp.robot, exp.task, state)
        res = law(J1=state.J1, e1=state.e1, q=q, limits=exp.limits, lam=0.5, dt=DT, qdot_prev=prev)
        assert "global model" in res.diagnostics.info[0]
        model = law.last_model
        pred = point_prediction(model, q, law.last_plan, law._hz, DT)
        uv = pred.s.reshape(law.horizon, -1, 2) * [cam.px, cam.py] + [cam.u0, cam.v0]
        now = state.s.reshape(-1, 2) * [cam.px, cam.py] + [cam.u0, cam.v0]
        lo = np.minimum(60.0, now) - 1.0
        hi = np.minimum(np.maximum([cam.width - 60.0, cam.height - 60.0], now), 1e9) + 1.0
        assert np.all(uv >= lo) and np.all(uv <= hi)
        q, prev = q + DT * res.qdot, res.qdot
        bMc, J = exp.robot.kinematics(q, check_limits=False)
        state = exp.task.evaluate(exp.scene, bMc, J, DT)


def test_warm_start_is_the_previous_plan_shifted() -> None:
    """The second solve linearises around the first plan shifted by one period (its last block
    repeated); after reset, around q̇_prev."""
    rng = np.random.default_rng(5)
    law = make_law("predictive")
    kw = _problem(rng)
    law(**kw)  # type: ignore[arg-type]
    first = law.last_plan.copy()
    law(**kw)  # type: ignore[arg-type]
    assert np.array_equal(law.last_start, np.vstack([first[1:], first[-1:]]))
    law.reset()
    law(**kw)  # type: ignore[arg-type]
    assert np.array_equal(law.last_start, np.tile(kw["qdot_prev"], (law.control_horizon, 1)))


def test_infeasible_horizon_is_flagged_and_falls_back_to_qp() -> None:
    """A joint moving fast toward its limit that the acceleration limit cannot stop in time:
    horizon-infeasible and solver-fallback are raised, the command is the qp law's (safety
    stage included), and it never contains NaN nor exceeds the velocity limit."""
    lim = JointLimits(
        np.full(3, -1.0), np.full(3, 1.0), qdot_max=np.full(3, 2.0), qddot_max=np.full(3, 0.5)
    )
    kw = {
        "J1": np.eye(3)[:2],
        "e1": np.array([0.3, -0.2]),
        "q": np.array([0.9, 0.0, 0.0]),
        "limits": lim,
        "lam": 0.5,
        "dt": DT,
        "qdot_prev": np.array([2.0, 0.0, 0.0]),
    }
    law = make_law("predictive")
    res = law(**kw)  # type: ignore[arg-type]
    d = res.diagnostics
    assert d.has(Flag.HORIZON_INFEASIBLE) and d.has(Flag.SOLVER_FALLBACK)
    assert any("qp" in note for note in d.notes)
    ref = make_law("qp", margin=law.margin)(**kw)  # type: ignore[arg-type]
    assert np.array_equal(res.qdot, ref.qdot)
    assert np.all(np.isfinite(res.qdot)) and np.all(np.abs(res.qdot) <= 2.0)
    assert law.last_plan is None


@pytest.mark.parametrize(
    ("options", "message"),
    [({"max_qp_iterations": 1}, "iteration limit"), ({"time_budget": 1e-12}, "time budget")],
)
def test_solver_limits_are_flagged_and_fall_back(options: dict[str, float], message: str) -> None:
    """daqp's iteration limit, or a time budget no solve can meet (1 ps, so the outcome does
    not depend on the machine): solver-iterations and solver-fallback, the qp law's command."""
    exp, state = _panda_state()
    law = make_law("predictive", **options)
    law.observe(exp.robot, exp.task, state)
    kw = {"J1": state.J1, "e1": state.e1, "q": exp.q0, "limits": exp.limits, "lam": 0.5, "dt": DT}
    res = law(**kw)  # type: ignore[arg-type]
    d = res.diagnostics
    assert d.has(Flag.SOLVER_ITERATIONS) and d.has(Flag.SOLVER_FALLBACK)
    assert any(message in note for note in d.notes)
    assert np.array_equal(res.qdot, make_law("qp", margin=law.margin)(**kw).qdot)


CLOSED_LOOP_SAMPLE = 11
"""A panda-near-limits start (seed 0) where every reactive law fails (found with
``redservo campaign panda-near-limits --samples 30 --seed 0``)."""


def test_predictive_solves_a_start_where_every_reactive_law_fails() -> None:
    from redservo import METHODS

    d = load_campaign("panda-near-limits")
    exp = build(draw_sample(d, 0, CLOSED_LOOP_SAMPLE).scenario)
    for method in METHODS:
        if method in ("predictive", "qp-goal"):  # qp-goal: steered by the same joint goal
            continue
        summary, _ = fast_run(exp, method, d.method_options.get(method))
        if summary is None:
            summary = exp.run(method=method).summary
        assert not summary.success, method
    summary = exp.run(method="predictive").summary
    assert summary.success and summary.outcome == "converged"
    assert summary.velocity_violations == 0 and summary.acceleration_violations == 0
    assert summary.shield_activations == 0
