"""``qp-goal``: the ``qp`` law steered by the predictive law's joint goal, and its joint move at
a stall (:mod:`redservo.redundancy.qp_goal`, :mod:`redservo.redundancy.goal_move`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from redservo import ConfigurationError, Flag, make_law
from redservo.campaign.definition import load_campaign
from redservo.campaign.sampling import draw_sample
from redservo.experiment.build import build
from redservo.redundancy.goal_move import (
    MARGIN_PX,
    PAIR_PX,
    STEP_PX,
    XI,
    centroid_rows,
    image_rows,
    pair_rows,
)
from redservo.redundancy.predictive_goal import TOL, goal_error
from redservo.redundancy.qp_goal import goal_term, kept_goal
from redservo.scenario import load_scenario
from tests.test_predictive import DT, _panda_state


def _panda_law(**options: Any) -> tuple[Any, Any, Any, dict[str, Any]]:
    """The law observed on the Panda 4-point task at its start, the experiment, the state and
    the law's keywords."""
    exp, state = _panda_state()
    law = make_law("qp-goal", **options)
    kw = {"J1": state.J1, "e1": state.e1, "q": exp.q0, "limits": exp.limits, "lam": 0.5, "dt": DT}
    return law, exp, state, kw


def test_goal_term_is_the_gradient_step_and_vanishes_at_the_goal() -> None:
    """``-k (q - q*)`` is ``-k ∇ ½‖q - q*‖²`` (central differences) and 0 at ``q = q*``."""
    rng = np.random.default_rng(3)
    q, goal, k = rng.normal(size=7), rng.normal(size=7), 0.7
    cost = lambda v: 0.5 * float((v - goal) @ (v - goal))  # noqa: E731
    h = 1e-6
    grad = np.array([(cost(q + h * d) - cost(q - h * d)) / (2 * h) for d in np.eye(7)])
    np.testing.assert_allclose(goal_term(q, goal, k), -k * grad, rtol=1e-7, atol=1e-9)
    assert not np.any(goal_term(goal, goal, k))


def test_without_a_model_or_at_the_goal_it_is_qp() -> None:
    """A bare call (no observation: no goal) gives ``qp``'s command; a goal at ``q`` adds a
    zero term: ``qp``'s command again, under the law's own name."""
    law, exp, _, kw = _panda_law()
    ref = make_law("qp")(**kw).qdot
    res = law(**kw)
    assert law.goal is None and np.array_equal(res.qdot, ref)
    assert res.diagnostics.method == "qp-goal"
    law.goal = exp.q0.copy()
    np.testing.assert_array_equal(law(**kw).qdot, ref)


def test_the_goal_found_has_the_desired_features_within_the_band_and_is_kept() -> None:
    """Observed on the Panda task, the law finds ``q*`` within the limits less its band whose
    error under the model is below the search's tolerance, spread over periods; a later
    search's result replaces it only when it no longer holds."""
    law, exp, state, kw = _panda_law()
    for _ in range(40):
        law.observe(exp.robot, exp.task, state)
        law(**kw)
        if law.goal is not None:
            break
    goal = law.goal
    assert goal is not None
    lim = exp.limits
    band = law.margin * (lim.q_max - lim.q_min)
    assert np.all(goal >= lim.q_min + band - 1e-12)
    assert np.all(goal <= lim.q_max - band + 1e-12)
    law.observe(exp.robot, exp.task, state)
    model = law._model.build(exp.q0, DT)
    assert goal_error(model, goal) < TOL
    other = (0.0, exp.q0.copy())
    assert kept_goal(model, goal, other) is goal  # still holds
    assert kept_goal(model, exp.q0, (0.0, goal)) is goal  # q0 is no goal
    assert kept_goal(model, goal, None) is goal and kept_goal(model, None, None) is None


def test_stall_starts_the_move_and_flags_it() -> None:
    """With ``‖e1‖`` held constant (no progress) for ``stall`` periods and a goal away from
    ``q``, the law moves to the goal with the task relaxed: flagged ``task-scaled`` = 0."""
    law, exp, state, kw = _panda_law(stall=5)
    lim = exp.limits
    law.goal = np.clip(exp.q0 + 0.05 * (lim.q_max - lim.q_min), lim.q_min, lim.q_max)
    law._started = True  # the goal is given: no search
    moved = None
    for i in range(7):
        law.observe(exp.robot, exp.task, state)
        res = law(**kw)
        if law.moving:
            moved = (i, res)
            break
    assert moved is not None and moved[0] == 5
    d = moved[1].diagnostics
    assert d.has(Flag.TASK_SCALED) and d.value(Flag.TASK_SCALED) == 0.0
    step = moved[1].qdot * DT
    toward = (law.goal - exp.q0) @ step
    assert toward > 0.0  # toward the goal


def _decay(law: Any, rate: float, periods: int, level: float | None) -> bool:
    """Feed ``law._stalled`` ``periods`` sizes of ``‖e1‖`` decaying at ``rate`` of the nominal
    λ = 0.5 1/s (from 0.01), with ``qp``'s residual level ``r ‖e1‖`` held at ``level`` (None:
    not held); True when any call says stalled."""
    stalled = False
    for k in range(periods):
        if level is not None:
            law._held, law._level = law._held + 1, level
        stalled |= law._stalled(0.01 * float(np.exp(-rate * 0.5 * k * DT)), 0.5, DT)
    return stalled


def test_a_slow_decay_is_no_stall_a_level_held_above_the_tolerance_is() -> None:
    """A decay at 40 % of λ is no stall while ``qp``'s residual level stays below the
    tolerance (it converges, slowly: panda-near-limits sample 125), a stall when the bounds
    hold the task at a level above it; a decay below 25 % of λ is a stall either way, and a
    decay at the nominal rate never is."""
    law = make_law("qp-goal")
    assert law.gain == 0.0 and law.tolerance == 0.001
    assert not _decay(law, 0.4, 200, None)
    law.reset()
    assert not _decay(law, 0.4, 200, 0.0008)  # held, but toward a level below the tolerance
    law.reset()
    assert _decay(law, 0.4, 200, 0.004)  # held at 4x the tolerance: qp's KKT point
    law.reset()
    assert _decay(law, 0.2, 200, None)
    law.reset()
    assert not _decay(law, 1.0, 200, 0.004)


def test_qp_goal_is_qp_where_qp_converges_slowly() -> None:
    """panda-near-limits sample 125 (seed 0): ``qp`` converges in 342 periods, the last ones
    slowly with its residual above 0.5; ``qp-goal`` takes no stall there and gives ``qp``'s
    run (the branch ``reactgoal`` switched at period 248 and ended at the cap)."""
    exp = _sample("panda-near-limits", 125)
    ref = exp.run(method="qp")
    res = exp.run(method="qp-goal")
    assert ref.summary.outcome == res.summary.outcome == "converged"
    assert res.summary.iterations == ref.summary.iterations
    np.testing.assert_allclose(res.log.q, ref.log.q, atol=1e-9)


@pytest.mark.parametrize("seed", range(12))
def test_the_move_keeps_every_limit_and_the_image(seed: int) -> None:
    """Fuzzed (random q within the limits, previous command, goal): the move's command is
    finite, within the velocity limits, keeps ``q + dt q̇`` within the limits less the
    shield's margin, and moves no image point more than the step or past the border rows."""
    rng = np.random.default_rng(seed)
    law, exp, state, kw = _panda_law(stall=1)
    lim = exp.limits
    span = lim.q_max - lim.q_min
    q = np.clip(exp.q0 + rng.normal(0.0, 0.02, 7) * span, lim.q_min + 0.011 * span, lim.q_max)
    q = np.minimum(q, lim.q_max - 0.011 * span)
    prev = rng.uniform(-0.3, 0.3, 7) if seed % 2 else rng.uniform(-0.01, 0.01, 7)
    goal = np.clip(
        exp.q0 + rng.normal(0.0, 0.1, 7) * span, lim.q_min + 0.02 * span, lim.q_max - 0.02 * span
    )
    law.goal, law._started, law.moving = goal, True, True
    law.observe(exp.robot, exp.task, state)
    res = law(**{**kw, "q": q, "qdot_prev": prev})
    qd = res.qdot
    assert np.all(np.isfinite(qd))
    assert np.all(np.abs(qd) <= lim.qdot_max + 1e-12)
    assert np.all(q + DT * qd >= lim.q_min + lim.margin_abs - 1e-12)
    assert np.all(q + DT * qd <= lim.q_max - lim.margin_abs + 1e-12)
    assert not res.diagnostics.has(Flag.SHIELD_ACTED)
    assert res.diagnostics.value(Flag.TASK_SCALED) == 0.0  # the move, not the task law
    law.observe(exp.robot, exp.task, state)
    rows = centroid_rows(law._model.build(q, DT), q, goal)
    assert rows is not None
    S, bl, bu = image_rows(rows, exp.camera, DT)
    move = S @ qd
    tol = 1e-6 * (1.0 + np.abs(move))
    assert np.all(move >= bl - tol) and np.all(move <= bu + tol)
    assert np.all(np.abs(move) * DT <= STEP_PX / exp.camera.px * (1 + 1e-6))
    G, bl, bu = pair_rows(rows, exp.camera, DT)
    part = G @ qd
    tol = 1e-6 * (1.0 + np.abs(part))
    assert np.all(part >= bl - tol) and np.all(part <= bu + tol)


def test_image_rows_damp_the_border() -> None:
    """A point at the image border less the margin may not move outwards; one in the middle
    may move at most the step per period."""
    _, exp, state, _ = _panda_law()
    cam = exp.camera
    law = make_law("qp-goal")
    law.observe(exp.robot, exp.task, state)
    rows = centroid_rows(law._model.build(exp.q0, DT), exp.q0, exp.q0)
    assert rows is not None
    edge = (cam.width - MARGIN_PX - cam.u0) / cam.px
    s = rows.s.copy()
    s[0] = edge
    _, bl, bu = image_rows(rows._replace(s=s), cam, DT)
    assert bu[0] == pytest.approx(0.0, abs=1e-15)
    assert bl[0] == pytest.approx(-STEP_PX / cam.px / DT)


def test_pair_rows_keep_two_points_apart() -> None:
    """Two points at :data:`PAIR_PX` may not come closer; farther apart they close at most
    :data:`XI` of the gap per period; closer, they part (by :data:`XI` of the gap, at most
    half a step per period, or may stay with ``back`` = 0); the row is the distance's derivative (finite differences)."""
    _, exp, state, _ = _panda_law()
    cam = exp.camera
    law = make_law("qp-goal")
    law.observe(exp.robot, exp.task, state)
    rows = centroid_rows(law._model.build(exp.q0, DT), exp.q0, exp.q0)
    assert rows is not None
    step = STEP_PX / cam.px / DT
    for gap_px, low in [(PAIR_PX, 0.0), (3 * PAIR_PX, -XI * 2 * PAIR_PX / cam.px / DT)]:
        s = rows.s.copy()
        s[2:4] = s[0:2] + np.array([gap_px / cam.px, 0.0])
        _, bl, _ = pair_rows(rows._replace(s=s), cam, DT)
        assert bl[0] == pytest.approx(low, abs=1e-12)
    s = rows.s.copy()
    s[2:4] = s[0:2] + np.array([0.25 * PAIR_PX / cam.px, 0.0])
    part = min(XI * 0.75 * PAIR_PX / cam.px / DT, 0.5 * step)
    assert pair_rows(rows._replace(s=s), cam, DT)[1][0] == pytest.approx(part)
    assert pair_rows(rows._replace(s=s), cam, DT, back=0.0)[1][0] == 0.0
    G = pair_rows(rows, cam, DT)[0]
    v = np.random.default_rng(0).normal(size=7)
    h = 1e-7
    xy = rows.s.reshape(-1, 2)
    moved = (rows.s + h * rows.S @ v).reshape(-1, 2)
    d0, d1 = np.linalg.norm(xy[0] - xy[1]), np.linalg.norm(moved[0] - moved[1])
    assert G[0] @ v == pytest.approx((d1 - d0) / h, rel=1e-5)


@pytest.mark.parametrize(
    ("option", "value"), [("gain", -1.0), ("stall", 0), ("arrive", 0.0), ("goal_gain", np.nan)]
)
def test_bad_options_are_one_configuration_error(option: str, value: Any) -> None:
    with pytest.raises(ConfigurationError) as info:
        make_law("qp-goal", **{option: value})
    assert info.value.argument == option


def _sample(campaign: str, index: int) -> Any:
    return build(draw_sample(load_campaign(campaign), 0, index).scenario)


def test_closed_loop_converges_where_qp_stalls() -> None:
    """mc05-joint-limits sample 18 (seed 0): ``qp`` stalls at a joint bound until the
    iteration cap; ``qp-goal`` moves to its goal and converges, with no limit exceeded and
    the shield never acting."""
    exp = _sample("mc05-joint-limits", 18)
    qp = exp.run(method="qp").summary
    assert qp.outcome == "max_iterations"
    res = exp.run(method="qp-goal")
    s = res.summary
    assert s.outcome == "converged"
    assert s.shield_activations == 0
    assert s.velocity_violations == 0 and s.acceleration_violations == 0


def test_closed_loop_on_a_panda_sample_where_qp_stalls() -> None:
    """panda-near-limits sample 33 (seed 0): ``qp`` stalls at the joint band until the cap;
    ``qp-goal`` converges with every joint 1 % of its range off its limits all along, no limit
    exceeded, the shield never acting."""
    exp = _sample("panda-near-limits", 33)
    assert exp.run(method="qp").summary.outcome == "max_iterations"
    s = exp.run(method="qp-goal").summary
    assert s.outcome == "converged" and s.min_margin >= 0.01
    assert s.shield_activations == 0
    assert s.velocity_violations == 0 and s.acceleration_violations == 0


def test_the_urdf_start_near_a_limit_converges_as_qp_does(tmp_path: Path) -> None:
    """docs/choosing-a-law.md's worked example (``panda-urdf-4points``, joint 3 at -3.0 rad):
    ``qp`` converges in 384 periods with a slow decay at the end; ``qp-goal`` takes no stall
    there and converges in the same periods (``reactgoal`` switched at 189 and failed)."""
    from tests.test_advice import _near_limit

    exp = build(load_scenario(_near_limit(tmp_path)))
    s = exp.run(method="qp-goal").summary
    assert s.outcome == "converged" and s.iterations == 384
    assert s.shield_activations == 0 and s.min_margin >= 0.01


def test_through_the_camera_the_move_keeps_the_dots_apart() -> None:
    """mc05-joint-limits sample 13 (seed 0) through the ``realistic`` camera: ``qp`` stalls;
    ``qp-goal``'s move brought two dots within 5 px of each other, the tracker lost one and
    the run ended ``feature_lost`` (branch ``reactgoal``); with the pair rows it converges."""
    from redservo.experiment.camera_presets import camera_overrides
    from redservo.scenario import apply_overrides

    sc = draw_sample(load_campaign("mc05-joint-limits"), 0, 13).scenario
    exp = build(apply_overrides(sc, camera_overrides("realistic")))
    s = exp.run(method="qp-goal").summary
    assert s.outcome == "converged" and s.success
    assert s.shield_activations == 0 and s.velocity_violations == 0
