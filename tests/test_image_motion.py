"""The camera-motion limit (redservo.control.image_motion): its scale never lets an image
point move further between two frames than allowed, the Controller applies it on both its
engines with a typed flag, and bad settings are one clear error."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from redservo import make_law
from redservo.control import Controller, ImageMotionLimit, Measurement
from redservo.control.image_motion import image_motion_scale
from redservo.errors import ConfigurationError
from redservo.features import PointFeature
from redservo.redundancy.flags import Flag


def test_the_scale_never_lets_a_point_exceed_the_limit() -> None:
    """Fuzzed interaction matrices, Jacobians and commands: after the scaling, the fastest
    point moves at most max_motion per frame and smears at most max_blur per exposure."""
    rng = np.random.default_rng(3)
    for trial in range(2000):
        k2 = int(rng.integers(1, 6))
        n = int(rng.integers(1, 10))
        L = rng.normal(size=(2 * k2, 6)) * 10.0 ** rng.uniform(-2, 2)
        J = rng.normal(size=(6, n))
        qdot = rng.normal(size=n) * 10.0 ** rng.uniform(-4, 2)
        lim = ImageMotionLimit(
            max_motion=10.0 ** rng.uniform(-4, -1),
            frame_period=10.0 ** rng.uniform(-3, -1),
            max_blur=10.0 ** rng.uniform(-4, -1) if trial % 2 else math.inf,
            exposure=10.0 ** rng.uniform(-4, -2) if trial % 3 else 0.0,
        )
        rows = np.arange(0, 2 * k2, 2)
        scale, _ = image_motion_scale(L, J, qdot, rows, lim)
        assert 0.0 < scale <= 1.0
        sdot = L @ (J @ (scale * qdot))
        speed = np.max(np.hypot(sdot[rows], sdot[rows + 1]))
        assert speed * lim.frame_period <= lim.max_motion * (1 + 1e-12)
        if lim.exposure > 0 and math.isfinite(lim.max_blur):
            assert speed * lim.exposure <= lim.max_blur * (1 + 1e-12)
        if scale < 1.0:  # no more scaling than needed
            assert speed == pytest.approx(lim.max_speed, rel=1e-9)


def test_from_camera_derives_the_bound_from_the_tracker_gate() -> None:
    lim = ImageMotionLimit.from_camera(focal_px=800.0, gate_px=20.0, frame_period=1 / 30)
    assert lim.max_motion == pytest.approx(0.5 * 20.0 / 800.0)
    assert lim.max_speed == pytest.approx(lim.max_motion * 30)


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"max_motion": -1.0, "frame_period": 0.03}, "max_motion"),
        ({"max_motion": 0.01, "frame_period": math.nan}, "frame_period"),
        ({"max_motion": 0.01, "frame_period": 0.03, "exposure": -0.001}, "exposure"),
        ({"max_motion": 0.01, "frame_period": 0.03, "max_blur": 0.0}, "max_blur"),
        ({"max_motion": True, "frame_period": 0.03}, "max_motion"),
    ],
)
def test_bad_settings_are_one_clear_error(kwargs: dict[str, float], argument: str) -> None:
    with pytest.raises(ConfigurationError) as err:
        ImageMotionLimit(**kwargs)
    assert err.value.argument == argument


def test_from_camera_refuses_a_fraction_above_one() -> None:
    with pytest.raises(ConfigurationError, match="fraction"):
        ImageMotionLimit.from_camera(focal_px=800, gate_px=20, frame_period=0.03, fraction=2)


def _setup() -> tuple[object, ...]:
    from redservo.bench.cases import bench_cases

    c = bench_cases(scaling=())[0]  # the Afma6 and four points
    bMc, J = c.robot.kinematics(c.q)
    meas = Measurement(*c.task.measure(c.scene, bMc, 0.0))
    return c, J, meas


@pytest.mark.parametrize("engine", ["auto", "python"])
def test_the_controller_scales_a_fast_command_and_flags_it(engine: str) -> None:
    """A high gain on the Afma6's four points: without the limit the points would move
    further per frame than allowed; with it they do not, on the compiled and the Python
    engine alike, and the diagnostics say so."""
    c, J, meas = _setup()
    lim = ImageMotionLimit(max_motion=1e-4, frame_period=1 / 30)
    free = Controller(c.robot, c.task, make_law("classical"), c.limits, lam=5.0, dt=0.04)
    held = Controller(
        c.robot,
        c.task,
        make_law("classical"),
        c.limits,
        lam=5.0,
        dt=0.04,
        image_motion=lim,
        engine=engine,
    )
    a = free.step(c.q, meas, 0.0, qdot_prev=None)
    b = held.step(c.q, meas, 0.0, qdot_prev=None)
    rows = np.arange(0, c.task.k, 2)
    scale, _ = image_motion_scale(b.state.L, J, a.qdot, rows, lim)
    assert scale < 1.0  # the unlimited command breaks the limit
    np.testing.assert_allclose(b.qdot, scale * a.qdot, rtol=1e-12, atol=1e-15)
    assert b.diagnostics is not None and b.diagnostics.has(Flag.CAMERA_MOTION_LIMITED)
    assert b.diagnostics.value(Flag.CAMERA_MOTION_LIMITED) == pytest.approx(scale)
    sdot = b.state.L @ (J @ b.qdot)
    assert np.max(np.hypot(sdot[rows], sdot[rows + 1])) / 30 <= 1e-4 * (1 + 1e-9)


def test_a_slow_command_is_left_alone() -> None:
    c, _, meas = _setup()
    lim = ImageMotionLimit(max_motion=10.0, frame_period=1 / 30)
    free = Controller(c.robot, c.task, make_law("classical"), c.limits, lam=0.5, dt=0.04)
    held = Controller(
        c.robot, c.task, make_law("classical"), c.limits, lam=0.5, dt=0.04, image_motion=lim
    )
    a = free.step(c.q, meas, 0.0, qdot_prev=None)
    b = held.step(c.q, meas, 0.0, qdot_prev=None)
    assert np.array_equal(a.qdot, b.qdot)
    assert b.diagnostics is not None and not b.diagnostics.has(Flag.CAMERA_MOTION_LIMITED)


def test_the_controller_refuses_something_else_as_the_limit() -> None:
    c, _, _ = _setup()
    with pytest.raises(ConfigurationError) as err:
        Controller(c.robot, c.task, make_law("classical"), lam=0.5, dt=0.04, image_motion=0.1)  # type: ignore[arg-type]
    assert err.value.argument == "image_motion"


def test_simulate_gives_the_limit_to_its_controller_and_campaigns_take_the_object_path() -> None:
    """The option reaches the Controller that simulate drives; the compiled campaign loop
    (which has no camera-motion limit) hands such runs to the object path with a reason."""
    import dataclasses

    from redservo.campaign.fastloop import experiment_reason
    from redservo.experiment.build import build
    from redservo.scenario import load_scenario
    from redservo.simulation import SimulationOptions
    from redservo.simulation.loop import simulation_controller

    c, _, _ = _setup()
    lim = ImageMotionLimit(max_motion=1e-3, frame_period=1 / 30)
    opt = SimulationOptions(image_motion=lim)
    ctl = simulation_controller(c.robot, c.task, make_law("classical"), opt)
    assert ctl.image_motion is lim
    exp = build(load_scenario("panda-4points"))
    assert experiment_reason(exp) is None
    limited = dataclasses.replace(exp, options=dataclasses.replace(exp.options, image_motion=lim))
    assert experiment_reason(limited) == "camera-motion limit"


@pytest.mark.parametrize(
    ("table", "old", "new"),
    [
        ("simulation", "qdot_max", "qdot_saturation"),
        ("actuators", "qdot_max", "velocity_saturation"),
        ("actuators", "qddot_max", "acceleration_saturation"),
    ],
)
def test_qdot_max_means_one_thing_in_a_scenario_file(table: str, old: str, new: str) -> None:
    """The output saturation and the drives' saturations have names of their own; the old
    key is one error that names the new one, and the new key works."""
    from redservo.errors import ScenarioError
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    sc = load_scenario("panda-4points")
    with pytest.raises(ScenarioError, match=f"{table}.{old}.*renamed: write {new}"):
        apply_overrides(sc, [f"{table}.{old}=0.5"])
    exp = build(apply_overrides(sc, [f"{table}.{new}=0.5"]))
    if table == "simulation":
        assert exp.options.qdot_max == 0.5
    else:
        assert exp.actuator is not None


def test_the_servo_loop_honours_the_limit() -> None:
    """The servo loop drives the same Controller: with a tight limit its commands are scaled
    and the log's flag column says so; the run still converges, more slowly."""
    runs = {}
    for name, lim in (("free", None), ("held", ImageMotionLimit(2e-4, 1 / 30))):
        runs[name] = _servo_loop(max_iterations=2000, image_motion=lim).run()
    free, held = runs["free"], runs["held"]
    assert free.outcome == held.outcome == "converged"
    flag = held.log.flag(Flag.CAMERA_MOTION_LIMITED)
    assert np.isfinite(flag).any() and np.all(flag[np.isfinite(flag)] < 1.0)
    assert not np.isfinite(free.log.flag(Flag.CAMERA_MOTION_LIMITED)).any()
    assert len(held.log) > len(free.log)


def test_the_sensor_key_sets_the_limit_from_the_tracker_gate_and_the_rate() -> None:
    """``[sensor] motion_limit`` (the realistic preset sets it): the limit of the run's
    Controller, a fraction of the image sensor's gate per frame at the camera's rate."""
    from redservo.experiment.build import build
    from redservo.experiment.camera_presets import REALISTIC_MOTION_LIMIT, camera_overrides
    from redservo.scenario import apply_overrides, load_scenario
    from redservo.vision.sensor import tracking_gate_px

    sc = load_scenario("panda-4points")
    assert build(sc).options.image_motion is None
    exp = build(apply_overrides(sc, camera_overrides("realistic")))
    lim = exp.options.image_motion
    assert lim is not None and lim.frame_period == pytest.approx(1 / 30)
    gate = tracking_gate_px(getattr(exp.sensor, "sensor", exp.sensor))  # inside the timing
    f = min(exp.camera.px, exp.camera.py)
    assert gate is not None
    assert lim.max_motion == pytest.approx(REALISTIC_MOTION_LIMIT * gate / f)
    exp2 = build(apply_overrides(sc, ["sensor.motion_limit=0.25"]))
    assert exp2.options.image_motion is not None  # the ideal sensor: the default dot gate


def test_the_servo_loop_steps_at_the_present_with_the_measurement_stamped() -> None:
    """With latency compensation (the Controller's default) the servo loop steps its
    Controller at the present time and hands it the measurement stamped at its image's time
    (:mod:`redservo.control.latency` brings it forward); without it, at the stamp's time."""
    from redservo.hardware.protocols import FeatureMeasurement

    class Late:
        """The ideal source, its stamps 30 ms in the past (a camera's latency)."""

        def __init__(self, inner: Any) -> None:
            self.inner = inner

        def measure(self, t: float) -> FeatureMeasurement | None:
            m = self.inner.measure(t)
            return None if m is None else m._replace(t_measured=m.t_measured - 0.03)

    seen: dict[bool, list[tuple[float, float | None]]] = {}
    for compensate in (True, False):
        loop = _servo_loop(Late, max_iterations=20)
        loop.controller.compensate_latency = compensate
        calls = seen[compensate] = []
        step = loop.controller.step

        def spy(q: Any, m: Any, t: float, _step: Any = step, _calls: Any = calls, **kw: Any) -> Any:
            _calls.append((t, getattr(m, "stamp", None)))
            return _step(q, m, t, **kw)

        loop.controller.step = spy  # type: ignore[method-assign]
        loop.run()
    for t, stamp in seen[True]:
        assert stamp is not None and t - stamp == pytest.approx(0.03, abs=1e-9)
    assert all(stamp is None for _, stamp in seen[False])
    assert [t for t, _ in seen[False]] == pytest.approx([s for _, s in seen[True]])


def _servo_loop(wrap: Any = None, **kw: Any) -> Any:
    """A servo loop on the simulated Afma6 (ideal actuators, a virtual clock at 50 Hz) gazing
    at one point; ``wrap`` wraps its ideal feature source."""
    from redservo.hardware import (
        ActuatorModel,
        IdealFeatureSource,
        ServoLoop,
        SimulatedRobot,
        VirtualClock,
    )
    from redservo.robots import Afma6
    from redservo.scene import PointSet, Scene, Static
    from redservo.spatial import make_transform
    from redservo.task import TaskTerm, VisualTask

    q0 = np.array([0.0, 0.0, -0.5, 0.0, 0.0, 0.0])
    clock = VirtualClock(50.0)
    robot = Afma6()
    sim = SimulatedRobot(robot, ActuatorModel.ideal(), q0, clock, period=0.02)
    wMo = robot.fkine(q0) @ make_transform(t=(0.08, -0.05, 0.6))
    scene = Scene([PointSet("target", np.zeros((1, 3)), trajectory=Static(wMo))])
    task = VisualTask([TaskTerm(PointFeature(), "target")], [0.0, 0.0])
    source: Any = IdealFeatureSource(task, scene, sim)
    law, lim = make_law("classical"), robot.limits()
    timing = {"period": 0.02, "lam": 1.0, "clock": clock, "sleep": clock.sleep}
    return ServoLoop(sim, wrap(source) if wrap else source, robot, task, law, lim, **timing, **kw)
