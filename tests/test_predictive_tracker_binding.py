"""The simulated loops hand the ``predictive`` law its tracker's gate and its camera's rate
(``Predictive.bind_tracker``, from which its camera-motion limit is derived), also through a
camera's timing (:class:`redservo.sensors.timing.TimedSensor` wraps the image sensor) and
from the MuJoCo camera; the ideal sensor gives none (docs/predictive.md, "Camera motion")."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from redservo import make_law
from redservo._validation import FloatArray
from redservo.experiment.build import build
from redservo.experiment.camera_presets import REALISTIC_TIMING, camera_overrides
from redservo.redundancy.predictive import Predictive
from redservo.redundancy.predictive_camera import (
    BORDER_DAMPING,
    GATE_FRACTION,
    damped_image_bounds,
)
from redservo.redundancy.predictive_model import point_prediction
from redservo.scenario import apply_overrides, load_scenario, parse_scenario
from tests.test_predictive import DT, _panda_state


def _bound(monkeypatch: pytest.MonkeyPatch, exp: Any, iterations: int) -> list[Any]:
    """``exp`` run with ``predictive`` for ``iterations`` periods: the laws bound, each with
    the arguments of its ``bind_tracker`` call."""
    calls: list[Any] = []
    orig = Predictive.bind_tracker

    def record(self: Predictive, gate_px: float | None, frame_rate: float | None = None) -> None:
        calls.append((self, gate_px, frame_rate))
        orig(self, gate_px, frame_rate)

    monkeypatch.setattr(Predictive, "bind_tracker", record)
    exp.run(method="predictive", max_iterations=iterations)
    return calls


def test_through_the_cameras_timing_the_law_gets_the_trackers_gate_and_rate(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The realistic preset: the image sensor inside the 30 Hz camera's timing wrapper. On
    main the law got no gate (it asked the wrapper's module) and planned without its limit."""
    from redservo.vision.sensor import tracking_gate_px

    exp = build(apply_overrides(load_scenario("panda-4points"), camera_overrides("realistic")))
    calls = _bound(monkeypatch, exp, 2)
    assert len(calls) == 1
    law, gate, rate = calls[0]
    assert gate is not None and gate == pytest.approx(
        tracking_gate_px(getattr(exp.sensor, "sensor", exp.sensor))
    )
    assert rate == pytest.approx(REALISTIC_TIMING.rate)
    dt = exp.options.dt
    lim = law.motion_limit(dt)  # a fraction of the gate per frame, frames 1/rate apart
    assert lim is not None
    assert lim.limit_px == pytest.approx(GATE_FRACTION * gate * REALISTIC_TIMING.rate * dt)


def test_the_ideal_sensor_gives_no_gate_and_no_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    exp = build(load_scenario("panda-4points"))
    (law, gate, rate), *_ = _bound(monkeypatch, exp, 2)
    assert gate is None and rate is None and law.motion_limit(exp.options.dt) is None


def test_the_mujoco_camera_gives_its_trackers_gate() -> None:
    """The MuJoCo backend's image sensor (a subclass of the image sensor outside
    ``redservo.vision``), bare and through a camera's timing: on main the loop's lookup
    (by the sensor's module) gave it no gate either. No rendering is needed to build it."""
    pytest.importorskip("mujoco", reason="the MuJoCo backend needs redservo[mujoco]")
    from redservo.physics import MujocoCamera
    from redservo.sensors.timing import CameraTiming, TimedSensor
    from redservo.simulation.loop import _frame_rate, _tracking_gate
    from redservo.vision.sensor import tracking_gate_px

    data = copy.deepcopy(load_scenario("panda-mujoco-4points").data)
    data["simulator"]["camera"] = "ideal"  # the arm only: its camera is built here
    exp = build(parse_scenario(data, "ideal.toml"))
    cam = MujocoCamera(exp.actuator.arm, blur_px=1.0)
    gate = tracking_gate_px(cam)
    assert gate is not None and _tracking_gate(cam) == pytest.approx(gate)
    timing = CameraTiming(rate=30.0, latency=0.066)  # it renders only the present: no blur
    timed = TimedSensor(cam, timing, exp.options.dt)
    assert _tracking_gate(timed) == pytest.approx(gate)
    assert _frame_rate(timed) == pytest.approx(30.0)
    assert _frame_rate(cam) is None


def test_damped_image_bounds_close_a_fixed_share_of_the_gap_per_period() -> None:
    s_lo, s_hi = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    lo, hi = damped_image_bounds(s_lo, s_hi, np.array([0.5, 1.2]), 3)  # the 2nd is past s_hi
    keep = (1.0 - BORDER_DAMPING) ** np.arange(1, 4)
    np.testing.assert_allclose(hi[:, 0], 1.0 - keep * 0.5)
    np.testing.assert_allclose(lo[:, 0], -1.0 + keep * 1.5)
    np.testing.assert_allclose(hi[:, 1], 1.0)  # the QP relaxes it to the point
    np.testing.assert_allclose(lo[:, 1], -1.0 + keep * 2.2)


def _gaps(law: Any, bound: bool) -> tuple[FloatArray, FloatArray]:
    """Five periods of the Panda's plan towards a 60 px image margin: per period, the
    nonlinear prediction's smallest gap (px) of each point to the margin over the horizon,
    and ``(1 - ξ)^k`` times its gap now."""
    exp, state = _panda_state()
    if bound:
        law.bind_tracker(27.4, 30.0)
    q, prev, cam, m = exp.q0, np.zeros(exp.robot.n), exp.camera, 60.0
    got, floor = [], []
    for _ in range(5):
        law.observe(exp.robot, exp.task, state)
        res = law(J1=state.J1, e1=state.e1, q=q, limits=exp.limits, lam=0.5, dt=DT, qdot_prev=prev)
        pred = point_prediction(law.last_model, q, law.last_plan, law._hz, DT)
        uv = pred.s.reshape(law.horizon, -1, 2) * [cam.px, cam.py] + [cam.u0, cam.v0]
        now = state.s.reshape(-1, 2) * [cam.px, cam.py] + [cam.u0, cam.v0]
        size = np.array([cam.width, cam.height])
        gap_now = np.maximum(np.minimum(now - m, size - m - now), 0.0)
        keep = (1.0 - BORDER_DAMPING) ** np.arange(1, law.horizon + 1)[:, None, None]
        got.append(np.minimum(uv - m, size - m - uv))
        floor.append(keep * gap_now)
        q, prev = q + DT * res.qdot, res.qdot
        bMc, J = exp.robot.kinematics(q, check_limits=False)
        state = exp.task.evaluate(exp.scene, bMc, J, DT)
    return np.array(got), np.array(floor)


def test_through_a_camera_the_plan_slows_down_near_the_image_border() -> None:
    """With a tracker bound (a camera), each planned point keeps at least ``(1 - ξ)^k`` of
    its gap to the image margin at period ``k`` (nonlinear prediction, within 1 px, five
    SQP iterations); without one (the ideal sensor) the plan closes the gap faster. On main
    the bound law planned as the ideal one."""
    got, floor = _gaps(make_law("predictive", image_margin_px=60.0, sqp_iterations=5), True)
    assert np.all(got >= floor - 1.0)
    free, floor = _gaps(make_law("predictive", image_margin_px=60.0, sqp_iterations=5), False)
    assert np.any(free < floor - 1.0)
