"""Collision avoidance (redservo.control.avoidance): the repulsive objective, the distance
shield, the ``collision`` outcome, the log's closest pair and ``[collision]`` in scenarios."""

from __future__ import annotations

import dataclasses
import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo.cli.entry import main
from redservo.collision import Obstacle, Shape
from redservo.control.avoidance import (
    Collision,
    CollisionAvoidance,
    distance_shield,
    repulsive_command,
)
from redservo.errors import ConfigurationError, ScenarioError
from redservo.experiment.build import build
from redservo.redundancy.flags import Flag
from redservo.robots import make_robot
from redservo.runs.load import load_run
from redservo.scenario import load_scenario, parse_scenario
from redservo.scene import ConstantVelocity, Static
from redservo.spatial import make_transform


def _post_data() -> dict[str, Any]:
    text = resources.files("redservo.scenarios").joinpath("panda-post.toml").read_text()
    return tomllib.loads(text)


def _run(overrides: dict[str, Any], method: str = "gpm") -> Any:
    exp = build(load_scenario("panda-post"))
    coll = exp.options.collision
    assert coll is not None
    return exp.run(method=method, collision=dataclasses.replace(coll, **overrides))


# ------------------------------------------------------------------------------- the shield


_finite = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 6),
    st.integers(1, 7),
    st.data(),
    st.floats(1e-3, 0.1),
    st.floats(0.0, 0.05),
)
def test_shield_never_lets_a_predicted_distance_below_d_safe(
    pairs: int, n: int, data: st.DataObject, dt: float, d_safe: float
) -> None:
    d = np.array(data.draw(st.lists(st.floats(-0.05, 0.3), min_size=pairs, max_size=pairs)))
    J = np.array(data.draw(st.lists(_finite, min_size=pairs * n, max_size=pairs * n)))
    J = J.reshape(pairs, n)
    qdot = np.array(data.draw(st.lists(st.floats(-3.0, 3.0), min_size=n, max_size=n)))
    drift = np.array(data.draw(st.lists(st.floats(-0.5, 0.5), min_size=pairs, max_size=pairs)))
    s, k = distance_shield(qdot, d, J, dt=dt, d_safe=d_safe, drift=drift)
    assert 0.0 <= s <= 1.0
    assert (k == -1) == (s == 1.0)
    rate = J @ (s * qdot)
    rest = d + dt * drift
    clear = rest >= d_safe
    # Clear at rest: the first-order prediction stays at d_safe or above.
    assert np.all(rest[clear] + dt * rate[clear] >= d_safe - 1e-12)
    # Already inside d_safe (or pushed in by a moving obstacle): never closer.
    assert np.all(rate[~clear] >= -1e-15)


def test_shield_takes_an_approach_that_underflows_without_dividing_by_zero() -> None:
    # J q̇ = -5e-324 m/s: dt J q̇ underflows to 0 (this raised ZeroDivisionError).
    J, qdot = np.array([[-5e-324]]), np.array([1.0])
    assert distance_shield(qdot, np.array([0.0]), J, dt=0.0625, d_safe=0.0) == (0.0, 0)
    assert distance_shield(qdot, np.array([0.1]), J, dt=0.0625, d_safe=0.02) == (1.0, -1)


def test_shield_leaves_a_command_alone_when_nothing_comes_too_close() -> None:
    J = np.array([[1.0, 0.0], [0.0, -1.0]])
    qdot = np.array([0.5, -0.5])  # both pairs separate
    assert distance_shield(qdot, np.array([0.03, 0.0]), J, dt=0.04, d_safe=0.02) == (1.0, -1)
    # Closing at 0.5 m/s from 0.5 m: 2 cm in one period, far from d_safe.
    assert distance_shield(-qdot, np.array([0.5, 0.5]), J, dt=0.04, d_safe=0.02) == (1.0, -1)


def test_shield_scales_onto_d_safe_and_stops_a_pair_already_inside() -> None:
    J = np.array([[1.0, 0.0]])
    s, k = distance_shield(np.array([-1.0, 0.3]), np.array([0.03]), J, dt=0.04, d_safe=0.02)
    assert k == 0 and s == pytest.approx(0.25)  # 1 cm of room at 1 m/s over 40 ms
    s, k = distance_shield(np.array([-1.0, 0.3]), np.array([0.01]), J, dt=0.04, d_safe=0.02)
    assert (s, k) == (0.0, 0)


# ---------------------------------------------------------------------------- the repulsion


def test_repulsion_separates_every_near_pair_and_ignores_far_ones() -> None:
    rng = np.random.default_rng(3)
    J = rng.normal(size=(3, 7))
    d = np.array([0.05, 0.2, 0.019])
    cmd = repulsive_command(d, J, d_safe=0.02, d_influence=0.1, xi=0.1, damping=0.05)
    one = repulsive_command(d[:1], J[:1], d_safe=0.02, d_influence=0.1, xi=0.1, damping=0.05)
    assert J[0] @ one > 0.0  # the pair alone is pushed apart
    far = repulsive_command(d[1:2], J[1:2], d_safe=0.02, d_influence=0.1, xi=0.1, damping=0.05)
    assert np.all(far == 0.0)
    # The ramp: ξ (d_i - d)/(d_i - d_s) realised through the damped inverse.
    v = 0.1 * (0.1 - 0.05) / 0.08
    np.testing.assert_allclose(one, J[0] * v / (J[0] @ J[0] + 0.05**2))
    assert np.all(np.isfinite(cmd))


def test_moving_obstacle_drift_matches_finite_differences() -> None:
    robot = make_robot("panda")
    q = robot.ready_configuration()
    ball = Obstacle(
        "ball",
        Shape("sphere", radius=0.05),
        ConstantVelocity(
            make_transform(t=(0.5, 0.3, 0.5)),
            v=np.array([-0.2, 0.1, 0.05]),
            w=np.array([0.0, 0.0, 0.3]),
        ),
    )
    coll = Collision((ball,))
    t, h = 0.3, 1e-5
    pd = coll.measure(robot, q, t)
    ahead = Collision((ball,)).measure(robot, q, t + h)
    np.testing.assert_allclose(pd.drift, (ahead.d - pd.d) / h, atol=1e-5)
    assert np.any(np.abs(pd.drift) > 1e-3)


def test_objective_feeds_the_repulsion_to_the_secondary() -> None:
    robot = make_robot("panda")
    q = robot.ready_configuration()
    static = Static(make_transform(t=(0.3, 0.0, 0.95)))
    coll = Collision((Obstacle("ball", Shape("sphere", radius=0.05), static),), d_influence=0.5)
    pd = coll.measure(robot, q, 0.0)
    ctx: Any = type("Ctx", (), {"robot": robot, "q": q, "t": 0.0})()
    cmd, stop = CollisionAvoidance(coll)(ctx)
    assert stop is None and cmd is not None
    assert float(pd.J[np.argmin(pd.d)] @ cmd) > 0.0  # the closest pair moves apart
    off = CollisionAvoidance(dataclasses.replace(coll, avoid=False))(ctx)
    assert off == (None, None)


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"d_safe": -0.01}, "d_safe"),
        ({"d_safe": 0.1, "d_influence": 0.1}, "d_influence"),
        ({"xi": 0.0}, "xi"),
        ({"damping": float("nan")}, "damping"),
        ({"d_safe": "1"}, "d_safe"),
        ({"obstacles": ("ball",)}, "obstacles"),
    ],
)
def test_bad_collision_options_name_the_argument(kwargs: dict[str, Any], argument: str) -> None:
    with pytest.raises(ConfigurationError) as info:
        Collision(**kwargs)
    assert info.value.argument == argument


# ----------------------------------------------------------------------------- closed loop


def test_panda_post_collides_without_avoidance_and_converges_with_it(tmp_path: Path) -> None:
    off = _run({"enabled": False})
    assert off.outcome == "collision" and not off.summary.success
    hit = off.summary.collision
    assert hit is not None and hit["distance"] <= 0.0 and hit["pair"].endswith("/ball")
    assert off.summary.min_distance == hit["distance"]
    on = _run({})
    assert on.outcome == "converged" and on.summary.success
    assert on.summary.min_distance is not None and on.summary.min_distance >= 0.02
    # The log: the smallest distance and its pair at every step, also in the CSV and back.
    log = on.log
    assert log.min_distance is not None and log.closest_pair is not None
    assert np.all(np.isfinite(log.min_distance)) and np.all(log.closest_pair >= 0)
    assert log.pair_names and all(name.endswith("/ball") for name in log.pair_names)
    on.save(tmp_path / "run")
    header, first = (tmp_path / "run" / "log.csv").read_text().splitlines()[:2]
    pair = header.split(",").index("closest_pair")
    assert first.split(",")[pair] in log.pair_names
    run = load_run(tmp_path / "run")
    assert run.pair_names == log.pair_names
    np.testing.assert_array_equal(run.simulation_log().min_distance, log.min_distance)


def test_shield_alone_keeps_d_safe_on_the_compiled_engine() -> None:
    res = _run({"avoid": False})  # no objective: the compiled step, then the shield
    assert res.engine == "compiled"
    assert res.outcome != "collision"
    assert Flag.DISTANCE_SHIELD.label in res.summary.flags
    d = res.log.min_distance
    assert d is not None
    # First order: the curvature of the distance costs a few micrometres at most.
    assert float(np.min(d)) >= 0.02 - 1e-4


# ------------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("setting", "key", "message"),
    [
        ("collision.d_safe=0.2", "collision.d_influence", "must be > d_safe"),
        ("collision.d_safe=-1", "collision.d_safe", ">= 0"),
        ("collision.xi=0", "collision.xi", "> 0"),
        ("collision.bogus=1", "collision.bogus", "unknown key"),
        ("collision.self=1", "collision.self", "expected true or false"),
    ],
)
def test_bad_collision_keys_exit_2_in_one_line(
    setting: str, key: str, message: str, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    argv = ["run", "panda-post", "--set", setting, "--out", str(tmp_path / "o"), "-q"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert re.search(re.escape(key), err) and re.search(re.escape(message), err, re.I), err


def test_start_in_self_collision_names_the_links() -> None:
    data = _post_data()
    data["collision"]["self"] = True
    data["robot"]["q0"] = [-1.01, 1.52, -0.36, -2.62, 1.33, 1.03, -0.53]
    with pytest.raises(ScenarioError, match=r"key 'collision\.self'.*'panda_joint1' and 'ee'"):
        build(parse_scenario(data, "my.toml"))


def test_collision_for_a_robot_without_a_collision_model_names_the_key() -> None:
    text = resources.files("redservo.scenarios").joinpath("panda-urdf-4points.toml").read_text()
    data = tomllib.loads(text)
    data["collision"] = {"self": True}
    sc = parse_scenario(data, str(resources.files("redservo.scenarios") / "x.toml"))
    with pytest.raises(ScenarioError, match=r"key 'collision\.enabled'.*no built-in collision"):
        build(sc)


# -------------------------------------------------------------------------------- campaign


def test_obstacle_campaign_counts_collisions_per_method(tmp_path: Path) -> None:
    import json

    from redservo.campaign.stats import column_stats, stats_table

    # The same samples without avoidance: the object path, the collisions counted apart.
    argv = ["campaign", "panda-posts", "--samples", "3", "--methods", "gpm", "--workers", "1"]
    argv += ["--set", "collision.enabled=false", "--no-plot", "-q"]
    assert main([*argv, "--out", str(tmp_path / "off")]) == 0
    stats = json.loads((tmp_path / "off" / "campaign.json").read_text())["stats"]["gpm"]
    assert "collisions" in stats and stats["runs"] == 3
    assert "| collisions |" in (tmp_path / "off" / "campaign.md").read_text()
    # A collision is its own column, not an "error" among the other failures.
    col = column_stats(
        "m",
        np.array([False, True]),
        {"collision": 1, "converged": 1},
        {
            c: np.zeros(2)
            for c in (
                "iterations",
                "max_joint_speed",
                "max_cam_translation",
                "max_cam_rotation",
                "discontinuity",
                "min_margin",
                "peak_velocity_ratio",
            )
        },
        shield_runs=0,
        velocity_runs=0,
        flag_runs=(),
    )
    assert (col.collisions, col.other_failures) == (1, 0)
    assert "| 0 | 1 |" in stats_table([col])


def test_a_campaign_run_with_obstacles_measures_them_in_the_compiled_loop() -> None:
    """The compiled loop measures the pairs (kernels/loop_avoid.py): the run that drives
    through the ball ends with ``collision`` there, as on the object path."""
    pytest.importorskip("numba", reason="the compiled campaign loop needs numba")
    from redservo.campaign.engine import FAST_PATH
    from redservo.campaign.task import _run_task, _Task

    data = _post_data()
    data["collision"]["enabled"] = False
    row = _run_task(_Task(0, "gpm", data, "post.toml", None, {}, fast=True))
    slow = _run_task(_Task(0, "gpm", data, "post.toml", None, {}, fast=False))
    assert row["_path"] == FAST_PATH and row["outcome"] == "collision"
    assert {k: repr(v) for k, v in row.items() if k != "_path"} == {
        k: repr(v) for k, v in slow.items() if k != "_path"
    }


# ------------------------------------------------------------------------------ servo loop


@pytest.mark.parametrize("avoid", [False, True])
def test_servo_loop_keeps_d_safe_after_its_own_guard(avoid: bool) -> None:
    """On the servo loop of a (simulated) arm the shield acts again after the loop's guard,
    whose acceleration step would otherwise undo it; the repulsion is an objective."""
    from redservo.hardware import (
        ActuatorModel,
        IdealFeatureSource,
        ServoLoop,
        SimulatedRobot,
        VirtualClock,
    )

    exp = build(load_scenario("panda-post"))
    coll = dataclasses.replace(exp.options.collision, avoid=avoid)
    clock = VirtualClock()
    dt = exp.options.dt
    sim = SimulatedRobot(exp.robot, ActuatorModel.ideal(), exp.q0, clock, period=dt)
    loop = ServoLoop(
        sim,
        IdealFeatureSource(exp.task, exp.scene, sim),
        exp.robot,
        exp.task,
        exp.law,
        exp.limits,
        period=dt,
        lam=0.5,
        max_iterations=200,
        clock=clock,
        sleep=clock.sleep,
        objectives=[CollisionAvoidance(coll)] if avoid else [],
        collision=coll,
    )
    res = loop.run()
    probe = Collision(coll.obstacles)
    closest = min(probe.measure(exp.robot, q, 0.0).closest()[0] for q in res.log.q)
    assert closest >= 0.02 - 1e-4
    # The shield plans over max_hold (the watchdog's 0.5 s), so it acts with the repulsion too.
    assert Flag.DISTANCE_SHIELD.label in res.summary["flags"]
