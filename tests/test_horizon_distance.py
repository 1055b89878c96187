"""The predictive law's plan measured in one compiled call, broad phase first
(redservo.kernels.horizon_distance): the horizon's distance rows, the goal's clearance and the
campaigns' reachability verdict are those of the per-configuration measurement of every pair
they replace, bit for bit, on fuzzed plans among fuzzed obstacles."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from redservo.campaign.reach_obstacles import goal_clearance as reach_clearance
from redservo.collision import Obstacle, Shape
from redservo.control.avoidance import Collision, check_collision
from redservo.experiment.build import build
from redservo.kernels.horizon_distance import measure_plan
from redservo.kernels.loop_collide import measure_arm
from redservo.redundancy import make_law
from redservo.redundancy.predictive_distance import (
    HorizonRows,
    clear_of,
    goal_clearance,
    horizon_distance_rows,
)
from redservo.redundancy.predictive_model import horizon
from redservo.scenario import load_scenario
from redservo.scene import Static
from redservo.spatial import make_transform

D_I = 0.25


def _world(rng: np.random.Generator, self_pairs: bool) -> tuple[Any, Collision]:
    """panda-post's Panda among a post, a crate, two balls and a floor posed at random."""
    exp = build(load_scenario("panda-post"))
    coll = exp.options.collision
    assert coll is not None

    def at(t: Any) -> Static:
        return Static(make_transform(rotvec=rng.normal(0.0, 0.6, 3), t=t))

    obstacles = (
        Obstacle("post", Shape("cylinder", radius=0.03, length=1.0), at(rng.normal(0.4, 0.1, 3))),
        Obstacle("crate", Shape("box", size=(0.3, 0.1, 0.2)), at(rng.normal(0.3, 0.2, 3))),
        Obstacle("ball", Shape("sphere", radius=0.08), at(rng.normal(0.3, 0.2, 3))),
        Obstacle("rod", Shape("capsule", radius=0.02, length=0.4), at(rng.normal(0.2, 0.2, 3))),
        Obstacle("floor", Shape("plane"), Static(make_transform(t=[0.0, 0.0, -0.3]))),
    )
    c = dataclasses.replace(coll, obstacles=obstacles, self_collision=self_pairs, d_influence=D_I)
    return exp, c


def _rows_by_probe(law: Any, q0: Any, Ubar: Any, hz: Any, dt: float) -> HorizonRows | None:
    """The rows as main built them: every pair measured at each period, one call each."""
    c, robot = law._distance_source
    t0, ub = c.last_time, Ubar.reshape(-1)
    A, b, steps, names = [], [], [], []
    for k in range(1, hz.N + 1):
        w = dt * hz.M[k - 1]
        pd = c.probe(robot, q0 + w @ Ubar, t0 + k * dt)
        near = pd.d < c.d_influence
        if not np.any(near):
            continue
        Ak = np.concatenate([wj * pd.J[near] for wj in w], axis=1)
        A.append(Ak)
        b.append(np.minimum(c.d_safe - pd.d[near] + Ak @ ub, 0.0))
        steps += [k] * int(np.sum(near))
        names += [nm for nm, m in zip(pd.names, near, strict=True) if m]
    if not A:
        return None
    return HorizonRows(np.vstack(A), np.concatenate(b), tuple(steps), tuple(names))


def _clear_by_probe(c: Collision, robot: Any, q: Any) -> bool:
    d = c.probe(robot, q, c.last_time).d
    return bool(d.size == 0 or float(np.min(d)) >= c.d_safe)


@pytest.mark.parametrize("seed", range(4))
def test_the_plan_measurement_gives_every_near_pair_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    exp, c = _world(rng, self_pairs=bool(seed % 2))
    geo = c.compiled(exp.robot)
    assert geo is not None
    lim = exp.robot.limits()
    Q = lim.q_min + (lim.q_max - lim.q_min) * rng.uniform(0.0, 1.0, (30, exp.robot.n))
    skipped = 0
    for limit in (0.0, 0.02, D_I):
        D, JJ = measure_plan(Q, geo.arm, geo.geom, limit)
        for k in range(Q.shape[0]):
            d, J, _, _ = measure_arm(Q[k], geo.arm, geo.geom)
            done = D[k] != np.inf
            assert np.array_equal(D[k][done], d[done]) and np.array_equal(JJ[k][done], J[done])
            assert np.all(d[~done] > limit) and np.all(JJ[k][~done] == 0.0)
            assert clear_of(geo, limit)(Q[k]) == bool(np.min(d) >= limit)
            skipped += int(np.sum(~done))
    assert skipped > 0  # the broad phase did skip pairs


@pytest.mark.parametrize("seed", range(6))
def test_horizon_rows_and_clearance_are_main_s_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    exp, c = _world(rng, self_pairs=seed % 3 == 0)
    law = make_law("predictive")
    check_collision(c, exp.robot, law)
    clear = goal_clearance(law)
    reach = reach_clearance(SimpleNamespace(robot=exp.robot, options=SimpleNamespace(collision=c)))
    assert clear is not None and reach is not None
    n, dt, hz = exp.robot.n, 0.04, horizon(10, 3)
    seen_rows, widest = 0, 0
    for _ in range(25):
        q0 = exp.q0 + rng.normal(0.0, 0.4, n)
        Ubar = rng.normal(0.0, 0.6, (hz.Nc, n))
        c.measure(exp.robot, q0, 0.0)
        got, want = (
            horizon_distance_rows(law, q0, Ubar, hz, dt),
            _rows_by_probe(law, q0, Ubar, hz, dt),
        )
        assert (got is None) == (want is None)
        if got is not None and want is not None:
            assert got.steps == want.steps and got.names == want.names
            assert np.array_equal(got.A, want.A) and np.array_equal(got.b, want.b)
            seen_rows += len(got.steps)
            widest = max(widest, *(got.steps.count(k) for k in got.steps))
        for q in (q0, q0 + rng.normal(0.0, 0.3, n)):
            assert clear(q) == _clear_by_probe(c, exp.robot, q) == reach(q)
    # Periods of several rows (BLAS rounds A ū by the block's shape: one product a period).
    assert seen_rows > 0 and widest >= 5, (seen_rows, widest)
