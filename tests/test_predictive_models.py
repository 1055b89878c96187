"""The predictive law's global models and joint goal (docs/predictive.md): the moment model
recovers the target's pose from the features and the plane, its Jacobians match finite
differences, the joint goal is within the bounds with a zero predicted error, a better old
goal is kept, and an mc05-joint-limits start where the local model stalled is solved."""

from __future__ import annotations

import numpy as np

from redservo.campaign.definition import load_campaign
from redservo.campaign.sampling import draw_sample
from redservo.experiment.build import build
from redservo.redundancy.predictive_goal import (
    GoalSearch,
    better_goal,
    camera_goal,
    goal_error,
    joint_goal,
)
from redservo.redundancy.predictive_model import horizon, point_model
from redservo.redundancy.predictive_moments import PLANE_WEIGHT, estimate_pose, moment_model
from redservo.robots.ik import pose_error
from redservo.scenario import load_scenario
from redservo.spatial import inverse


def _state(exp, q):
    bMc, J = exp.robot.kinematics(q, check_limits=False)
    return bMc, exp.task.evaluate(exp.scene, bMc, J, 0.0)


def _true_cMo(exp, bMc):
    name = exp.task.terms[0].target
    return inverse(exp.scene.wMb @ bMc) @ exp.scene.wMo(name, 0.0)


def _mc05(rng):
    exp = build(load_scenario("mc05-joint-limits"))
    lim = exp.limits
    q = exp.q0 + rng.uniform(-0.05, 0.05, exp.robot.n) * (lim.q_max - lim.q_min)
    return exp, np.clip(q, lim.q_min, lim.q_max)


def test_moment_pose_estimate_recovers_the_pose() -> None:
    """From the six features and the plane alone (no guess, then warm-started), the
    estimated cMo is the true one to 1e-8 (the features alone leave a tilt ambiguity)."""
    rng = np.random.default_rng(3)
    for _ in range(4):
        exp, q = _mc05(rng)
        bMc, st = _state(exp, q)
        feat = exp.task.terms[0].feature
        truth = _true_cMo(exp, bMc)
        est = estimate_pose(feat, st.s, st.inv_depth[0], None)
        assert est is not None and np.max(np.abs(pose_error(est, truth))) < 1e-8
        guess = est.copy()
        guess[:3, 3] += 0.01
        warm = estimate_pose(feat, st.s, st.inv_depth[0], guess)
        assert warm is not None and np.max(np.abs(pose_error(warm, truth))) < 1e-8


def test_moment_model_predictions_and_jacobians() -> None:
    """The moment model predicts the features the task measures at the predicted joints, and
    its G = C L J matches central differences of e(q) (1e-6 relative)."""
    rng = np.random.default_rng(4)
    exp, q = _mc05(rng)
    bMc, st = _state(exp, q)
    model = moment_model(exp.robot, exp.task.terms[0].feature, exp.task, st, None, bMc)
    assert model is not None and model.cMo_star is not None
    hz = horizon(1, 1)
    U0 = np.zeros((1, exp.robot.n))
    q1 = q + rng.normal(0.0, 0.02, exp.robot.n)
    pred = model.predict(q1, U0, hz, 0.0)
    _, st1 = _state(exp, q1)
    assert np.allclose(pred.e[0], st1.e1, atol=1e-9)
    num = np.empty_like(pred.G[0])
    for j in range(exp.robot.n):
        d = np.zeros(exp.robot.n)
        d[j] = 1e-6
        hi, lo = model.predict(q1 + d, U0, hz, 0.0), model.predict(q1 - d, U0, hz, 0.0)
        num[:, j] = (hi.e[0] - lo.e[0]) / 2e-6
    assert np.allclose(pred.G[0], num, atol=1e-6 * np.max(np.abs(num)))
    uv = pred.s[0].reshape(-1, 2)
    Pc = model.feature.points_o @ _true_cMo(exp, exp.robot.kinematics(q1)[0])[:3, :3].T
    Pc += _true_cMo(exp, exp.robot.kinematics(q1)[0])[:3, 3]
    assert np.allclose(uv, Pc[:, :2] / Pc[:, 2:3], atol=1e-9)


def _panda_sample(i):
    d = load_campaign("panda-near-limits")
    exp = build(draw_sample(d, 0, i).scenario)
    _, st = _state(exp, exp.q0)
    model = point_model(exp.robot, exp.task, st, exp.q0)
    lim = exp.limits
    band = 0.0102 * (lim.q_max - lim.q_min)
    return exp, model, lim.q_min + band, lim.q_max - band


def test_joint_goal_meets_the_task_within_the_bounds() -> None:
    """The camera goal of the points is the scenario's desired pose; the joint goal lies
    within the bounds with a predicted error below 1e-5."""
    from redservo.campaign.reach import desired_camera_pose

    exp, model, lo, hi = _panda_sample(0)
    T = camera_goal(model, exp.robot.kinematics(exp.q0)[0])
    assert T is not None and np.max(np.abs(pose_error(T, desired_camera_pose(exp)))) < 1e-8
    gen = np.random.default_rng(0)
    seeds = [exp.q0] + [gen.uniform(lo, hi) for _ in range(20)]
    found = joint_goal(model, exp.q0, seeds, lo, hi)
    assert found is not None
    r, q_star = found
    assert r < 1e-5 and goal_error(model, q_star) == r
    assert np.all(q_star >= lo) and np.all(q_star <= hi)


def test_a_failed_search_keeps_the_previous_goal() -> None:
    """A search that found nothing keeps the previous goal (it still meets the task); a
    worse old goal gives way to a new exact one."""
    exp, model, lo, hi = _panda_sample(0)
    gen = np.random.default_rng(0)
    seeds = [exp.q0] + [gen.uniform(lo, hi) for _ in range(20)]
    found = joint_goal(model, exp.q0, seeds, lo, hi)
    assert found is not None
    good = found[1]
    assert better_goal(model, good, None) is good
    poor = np.clip(exp.q0, lo, hi)
    assert goal_error(model, poor) > 1e-3
    assert better_goal(model, poor, found) is good


def test_a_search_spread_over_periods_finds_the_same_goal() -> None:
    """With a deadline already past, the search runs one seed per call and ends, several
    calls later, with the goal the uninterrupted search finds (a servo loop's time budget)."""
    exp, model, lo, hi = _panda_sample(3)
    span = exp.limits.q_max - exp.limits.q_min
    whole, spread = GoalSearch(12), GoalSearch(12)
    whole.start(model, exp.q0, lo, hi, span)
    done, want = whole.advance(None)
    assert done and want is not None
    spread.start(model, exp.q0, lo, hi, span)
    calls = 0
    while True:
        calls += 1
        done, got = spread.advance(deadline=0.0)
        if done:
            break
    assert calls > 1 and not spread.running
    assert got is not None and np.array_equal(got[1], want[1])


MC05_SAMPLE = 7
"""An mc05-joint-limits start (seed 0) that the predictive law with the local model left
stalled at a joint band (‖e1‖ = 0.029 after 600 iterations) and the moment model solves."""


def test_moment_model_solves_a_start_the_local_model_did_not() -> None:
    d = load_campaign("mc05-joint-limits")
    exp = build(draw_sample(d, 0, MC05_SAMPLE).scenario)
    local = exp.run(method="predictive", law_options={"model": "local"}).summary
    assert not local.success
    summary = exp.run(method="predictive").summary
    assert summary.success and summary.outcome == "converged"
    assert summary.velocity_violations == 0 and summary.acceleration_violations == 0
    assert summary.shield_activations == 0


def test_the_simulation_binds_its_camera_to_the_law() -> None:
    """simulate() hands its camera to the law's image constraint (Law.bind_camera)."""
    import dataclasses

    from redservo import make_law
    from redservo.simulation.loop import simulate
    from redservo.simulation.options import SimulationOptions

    exp = build(load_scenario("panda-4points"))
    cam = dataclasses.replace(exp.camera, width=800, height=600, u0=400.0, v0=300.0)
    law = make_law("predictive")
    opt = SimulationOptions(max_iterations=2)
    simulate(exp.robot, exp.scene, exp.task, law, exp.q0, options=opt, camera=cam)
    assert law._camera is cam


def test_moment_model_through_a_depth_policy_plane() -> None:
    """An image sensor gives the plane of its depth policy (parallel to the image at the
    desired depth), which no pose shares with the features: the model is then built from
    the features alone (it was None at every period, after 16 starts each time), and the
    next period keeps that weight from its warm start."""
    rng = np.random.default_rng(5)
    exp, q = _mc05(rng)
    bMc, st = _state(exp, q)
    feat = exp.task.terms[0].feature
    policy = (np.array([0.0, 0.0, 1.0 / feat.desired_depth]),)
    assert np.max(np.abs(st.inv_depth[0] - policy[0])) > 0.05  # not the true plane
    model = moment_model(exp.robot, feat, exp.task, st._replace(inv_depth=policy), None, bMc)
    assert model is not None and model.plane_weight == 0.0
    cMo = inverse(bMc) @ model.bMo
    assert np.max(np.abs(model.feature.measure(cMo).s - st.s)) < 1e-6
    bMc1, st1 = _state(exp, q + 0.002)
    nxt = moment_model(exp.robot, feat, exp.task, st1._replace(inv_depth=policy), model, bMc1)
    assert nxt is not None and nxt.plane_weight == 0.0
    truth = moment_model(exp.robot, feat, exp.task, st, None, bMc)  # the measured plane
    assert truth is not None and truth.plane_weight == PLANE_WEIGHT
