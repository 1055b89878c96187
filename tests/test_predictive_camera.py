"""The predictive law respects the camera (issue 28, item 3): the image motion of each point
per period stays within a fraction of the tracker's gate, the measurement's latency is in
the model, the joint-goal search is spread over periods with its state carried, and a
servo loop gives the law a time budget by default (fake clocks only)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo import Flag, make_law
from redservo.errors import ConfigurationError
from redservo.redundancy.predictive_camera import GATE_FRACTION, MotionLimit, scale_to_limit
from redservo.redundancy.predictive_goal import GoalSearch
from redservo.redundancy.predictive_model import SeenJoints, point_model
from tests.test_predictive import DT, _panda_state


def _motion_px(law: Any, q: np.ndarray, u: np.ndarray, lim: MotionLimit) -> float:
    """The largest Euclidean pixel motion of a point in one period at ``u`` under the
    law's last model (the nonlinear prediction)."""
    from redservo.redundancy.predictive_model import horizon

    model = law.last_model
    pred = model.predict(q, u[None, :], horizon(1, 1), DT)
    return float(np.max(lim.pixels(pred.s[0] - model.s_now)))


@pytest.mark.parametrize("seed", range(6))
def test_the_image_motion_limit_is_never_exceeded_on_fuzzed_states(seed: int) -> None:
    """Random starts around the Panda's, random limits (2 to 20 px per frame, frames at 10 Hz
    to the control rate) and random previous commands that kept within them (the state the
    law leaves; from a faster camera, braking within the acceleration limit comes first, and
    at a joint limit the shield does), joints 5 % of their range off their limits: no
    image point moves more than the limit in the commanded period, fallback or not."""
    rng = np.random.default_rng(seed)
    exp, _ = _panda_state()
    lim_j = exp.limits
    for _ in range(4):
        band = 0.05 * (lim_j.q_max - lim_j.q_min)  # off the limits (there the shield wins)
        q = np.clip(
            exp.q0 + rng.normal(0.0, 0.15, exp.q0.shape), lim_j.q_min + band, lim_j.q_max - band
        )
        bMc, J = exp.robot.kinematics(q, check_limits=False)
        state = exp.task.evaluate(exp.scene, bMc, J, 0.0)
        px = float(rng.uniform(2.0, 20.0))
        rate = float(rng.choice([10.0, 12.5, 1.0 / DT, 30.0]))
        law: Any = make_law("predictive", max_image_motion_px=px, frame_rate=rate)
        law.observe(exp.robot, exp.task, state)
        model = law._obs(q, None)
        raw = rng.uniform(-1.0, 1.0, q.shape) * lim_j.qdot_max
        own = MotionLimit.resolve(
            normalized=None, pixels=px, gate_px=None, frame_rate=rate, dt=DT, camera=law._camera
        )
        prev = scale_to_limit(model, q, raw, DT, own)[0]
        law.observe(exp.robot, exp.task, state)
        res = law(J1=state.J1, e1=state.e1, q=q, limits=lim_j, lam=0.5, dt=DT, qdot_prev=prev)
        lim = law.motion_limit(DT)
        assert lim is not None and lim.limit_px == pytest.approx(px * rate * DT)
        assert _motion_px(law, q, res.qdot, lim) <= lim.limit_px * (1 + 1e-9)
        if res.diagnostics.has(Flag.TASK_SCALED):  # the exact check scaled it: flagged
            assert "camera-motion limit" in " ".join(e.message for e in res.diagnostics.events)


def test_the_default_limit_is_a_fraction_of_the_bound_trackers_gate() -> None:
    law: Any = make_law("predictive")
    assert law.motion_limit(DT) is None  # the ideal sensor: no tracker, no limit
    law.bind_tracker(25.0)
    lim = law.motion_limit(DT)
    assert lim.limit_px == pytest.approx(GATE_FRACTION * 25.0)
    law = make_law("predictive", max_image_motion=0.01)  # normalized, with the camera's px
    assert law.motion_limit(DT).limit_px == pytest.approx(0.01 * law._camera.px)


def test_both_motion_options_are_one_clear_error() -> None:
    with pytest.raises(ConfigurationError, match="max_image_motion_px"):
        make_law("predictive", max_image_motion=0.01, max_image_motion_px=5.0)
    with pytest.raises(ConfigurationError, match="frame_rate"):
        make_law("predictive", frame_rate=-30.0)


def test_the_plan_keeps_every_predicted_period_within_the_linearised_limit() -> None:
    """Without a scaling (a limit the plan meets), the QP's plan keeps each period's
    predicted motion near the limit (the rows are linearised: within 10 %)."""
    exp, state = _panda_state()
    law: Any = make_law("predictive", max_image_motion_px=4.0, sqp_iterations=3)
    law.observe(exp.robot, exp.task, state)
    law(J1=state.J1, e1=state.e1, q=exp.q0, limits=exp.limits, lam=0.5, dt=DT)
    U, model, lim = law.last_plan, law.last_model, law.motion_limit(DT)
    pred = model.predict(exp.q0, U, law._hz, DT)
    s = np.vstack([model.s_now, pred.s])
    assert np.max(lim.pixels(np.diff(s, axis=0))) <= 1.1 * lim.limit_px


def test_latency_puts_the_points_where_the_camera_saw_them() -> None:
    """A measurement taken at ``q_seen`` (the joints ``latency`` ago) and read at ``q``:
    with the latency in the model, the points in the base frame are the true ones and the
    present points are their projection at ``q``; without it they are off."""
    exp, _ = _panda_state()
    q_seen = exp.q0
    q_now = exp.q0 + 0.05
    bMc, J = exp.robot.kinematics(q_seen, check_limits=False)
    old = exp.task.evaluate(exp.scene, bMc, J, 0.0)  # what the camera measured then
    bMc, J = exp.robot.kinematics(q_now, check_limits=False)
    now = exp.task.evaluate(exp.scene, bMc, J, 0.0)  # what an undelayed camera gives now
    ok = point_model(exp.robot, exp.task, old, q_now, q_seen)
    naive = point_model(exp.robot, exp.task, old, q_now)
    assert np.allclose(ok.s_now, now.s, atol=1e-9)
    assert not np.allclose(naive.s_now, now.s, atol=1e-3)


def test_seen_joints_interpolate_the_past_periods() -> None:
    seen = SeenJoints(0.06)
    assert seen.push(np.array([0.0]), 0.04)[0] == pytest.approx(0.0)  # younger: the oldest
    seen.push(np.array([1.0]), 0.04)
    assert seen.push(np.array([2.0]), 0.04)[0] == pytest.approx(0.5)  # 1.5 periods ago
    assert SeenJoints(0.0).push(np.array([1.0]), 0.04) is None


def test_the_goal_search_state_is_carried_across_calls() -> None:
    """Advanced by 7 iterations a call, the search ends with the goal of the search run in
    one go, and no call runs more than 7 iterations."""
    exp, state = _panda_state()
    law: Any = make_law("predictive")
    law.observe(exp.robot, exp.task, state)
    model = law._obs(exp.q0, None)
    lim = exp.limits
    lo, hi, span = lim.q_min + 0.1, lim.q_max - 0.1, lim.q_max - lim.q_min
    search = GoalSearch(5)
    search.start(model, exp.q0, lo, hi, span)
    calls, result, done = 0, None, False
    while not done:
        done, result = search.advance(None, steps=7)
        assert 1 <= search.iterations <= 7
        calls += 1
    assert calls > 1
    whole = GoalSearch(5)
    whole.start(model, exp.q0, lo, hi, span)
    seeds = whole._steps  # the same seeds, run to the end in one call
    done, ref = whole.advance(None)
    assert done and seeds is not None
    assert (result is None) == (ref is None)
    if ref is not None:
        assert result is not None and np.array_equal(result[1], ref[1])


def test_each_law_step_runs_goal_steps_iterations_of_the_search() -> None:
    exp, _ = _panda_state()
    law: Any = make_law("predictive", goal_steps=3)
    runs: list[int] = []
    advance = law._search.advance

    def counted(*args: Any) -> Any:
        out = advance(*args)
        runs.append(law._search.iterations)
        return out

    law._search.advance = counted
    q = exp.q0
    for _ in range(4):
        bMc, J = exp.robot.kinematics(q, check_limits=False)
        st = exp.task.evaluate(exp.scene, bMc, J, 0.0)
        law.observe(exp.robot, exp.task, st)
        q = q + DT * law(J1=st.J1, e1=st.e1, q=q, limits=exp.limits, lam=0.5, dt=DT).qdot
    assert runs and all(r <= 3 for r in runs) and len(runs) == 4


def test_the_servo_loop_gives_the_law_a_share_of_its_period_on_its_clock() -> None:
    from tests.test_servo_loop import T, _loop, _setup

    clock, robot, sim, src, task = _setup()
    law: Any = make_law("predictive")
    loop = _loop(sim, src, robot, task, clock, law=law, max_iterations=2)
    loop.run()
    from redservo.redundancy.predictive_budget import LOOP_SHARE

    assert law.loop_budget == pytest.approx(LOOP_SHARE * T) and law.clock is clock
    assert law.time_budget is None  # the user's option is left as it was


def test_the_target_pose_gives_the_model_the_true_depths() -> None:
    """The image sensor's desired depths are off away from the goal: with model_depth
    "pose" the model's points in the base frame are the true ones (the pose estimated from
    the measured points and the target's own points); with the measured depths they are
    not."""
    from types import SimpleNamespace

    exp, state = _panda_state()
    wrong = SimpleNamespace(s=state.s, inv_depth=[np.asarray(d) * 0.6 for d in state.inv_depth])
    truth = point_model(exp.robot, exp.task, state, exp.q0)
    for depth, exact in (("pose", True), ("measured", False)):
        law: Any = make_law("predictive", model_depth=depth)
        law.observe(exp.robot, exp.task, wrong)
        model = law._obs(exp.q0, None)
        assert np.allclose(model.P_b, truth.P_b, atol=1e-6) is exact


def test_points_pose_from_a_rigid_fit_and_a_warm_start() -> None:
    from redservo.redundancy.predictive_pose import points_pose, rigid_fit
    from redservo.spatial import exp_twist

    rng = np.random.default_rng(3)
    P_o = np.array([[-0.05, -0.05, 0], [0.05, -0.05, 0], [0.05, 0.05, 0], [-0.05, 0.05, 0]])
    for _ in range(20):
        cMo = exp_twist(
            np.r_[rng.normal(0, 0.05, 2), 0.5 + rng.uniform(0, 0.3), rng.normal(0, 0.3, 3)]
        )
        Pc = P_o @ cMo[:3, :3].T + cMo[:3, 3]
        xy, iz = Pc[:, :2] / Pc[:, 2:3], 1.0 / Pc[:, 2]
        got = points_pose(P_o, xy, iz * rng.uniform(0.6, 1.5), None)
        assert got is not None and np.allclose(got, cMo, atol=1e-8)
        assert np.allclose(points_pose(P_o, xy, iz, got), cMo, atol=1e-8)
    assert np.allclose(rigid_fit(P_o, Pc), cMo, atol=1e-9)
    assert points_pose(P_o[:2], xy[:2], iz[:2], None) is None  # two points: no pose


class _Model:
    """A model of one point whose prediction moves it by ``u[0]`` (normalized) a period."""

    def __init__(self, s_now: float) -> None:
        self.s_now = np.array([s_now, 0.0])

    def predict(self, q: Any, U: np.ndarray, hz: Any, dt: float) -> Any:
        from redservo.redundancy.predictive_model import Prediction

        s = (self.s_now + np.array([U[0, 0], 0.0]))[None, :]
        return Prediction(np.zeros((1, 1)), np.zeros((1, 1, 1)), s, np.zeros((1, 2, 1)))


def test_the_limit_shrinks_when_the_points_move_faster_than_the_model_says() -> None:
    from redservo.redundancy.predictive_camera import MotionGain

    lim = MotionLimit(10.0, 600.0, 600.0)
    gain, q, u = MotionGain(), np.zeros(1), np.array([0.01])  # 6 px predicted a period
    s = 0.0
    for _ in range(8):  # the camera moves them 3x as far: 18 px
        out = gain.update(_Model(s), q, u, DT, lim)
        s += 0.03
    assert gain.gain == pytest.approx(3.0, rel=0.02)
    assert out.limit_px == pytest.approx(10.0 / gain.gain)
    gain.reset()
    assert gain.update(_Model(0.0), q, u, DT, lim) is lim
