"""The broad phase of the compiled loop (kernels/loop_cull.py): the pairs it skips change
nothing the records, the repulsion, the shield and its check use, bit for bit."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from redservo.collision import Obstacle, Shape
from redservo.collision.pack import compiled_geometry
from redservo.kernels.collide import capsule_capsule, segment_distance
from redservo.kernels.loop_collide import measure_arm, repulsive, shield_scale
from redservo.kernels.loop_cull import MARGIN, exact_scale, fill_for_shield, measure_culled
from redservo.robots import make_robot
from redservo.scene import Static
from redservo.spatial import make_transform

D_SAFE, D_I, DT = 0.02, 0.15, 0.01


def _scene(rng: np.random.Generator) -> tuple[Any, Any]:
    """The Panda among a post, a box, a ball and a floor, posed at random, self pairs on."""
    robot = make_robot("panda")

    def pose(t: Any) -> Static:
        return Static(make_transform(rotvec=rng.normal(0.0, 0.6, 3), t=t))

    obstacles = (
        Obstacle("post", Shape("cylinder", radius=0.03, length=1.0), pose([0.45, 0.0, 0.5])),
        Obstacle("crate", Shape("box", size=(0.3, 0.1, 0.2)), pose(rng.normal(0.3, 0.2, 3))),
        Obstacle("ball", Shape("sphere", radius=0.08), pose([0.3, 0.35, 0.5])),
        Obstacle("floor", Shape("plane"), Static(make_transform(t=[0.0, 0.0, -0.3]))),
    )
    geo = compiled_geometry(robot, obstacles, True, None)
    assert geo is not None
    return robot, geo


def _records(d: Any, kinds: Any) -> tuple[Any, ...]:
    """What collide_check logs and tallies from one measurement."""
    k = int(np.argmin(d))
    per_kind = tuple(float(np.min(d[kinds == x])) for x in (0, 1))
    return float(d[k]), k, per_kind, bool(d[k] < D_I), bool(d[k] <= 0.0)


def _same(a: Any, b: Any) -> bool:
    return bool(np.array_equal(np.asarray(a), np.asarray(b)))


@pytest.mark.parametrize("seed", range(6))
def test_the_culled_measurement_gives_the_full_outputs_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    robot, geo = _scene(rng)
    lim = robot.limits()
    kinds = np.array([0 if k == "environment" else 1 for k in geo.kinds])
    culled_seen = filled_seen = 0
    for _ in range(40):
        q = lim.q_min + (lim.q_max - lim.q_min) * rng.uniform(0.0, 1.0, robot.n)
        df, Jf, _, _ = measure_arm(q, geo.arm, geo.geom)
        d, J, lb, O, JO = measure_culled(q, geo.arm, geo.geom, D_I)
        assert np.all(lb < df)  # the bound, strictly
        done = d != np.inf
        assert _same(d[done], df[done]) and _same(J[done], Jf[done])
        assert np.all(J[~done] == 0.0) and np.all(df[~done] > D_I)
        culled_seen += int(np.sum(~done))
        assert _records(d, kinds) == _records(df, kinds)
        assert _same(
            repulsive(d, J, D_SAFE, D_I, 0.3, 0.01), repulsive(df, Jf, D_SAFE, D_I, 0.3, 0.01)
        )
        for scale in (0.5, 3.0, 30.0):  # rad/s: slow to far beyond the limits
            qd = rng.normal(size=robot.n) * scale
            dc, Jc = d.copy(), J.copy()
            filled_seen += fill_for_shield(qd, dc, Jc, (lb, O, JO), geo.geom, DT, D_I)
            sk = shield_scale(qd, dc, Jc, np.zeros(dc.shape[0]), DT, D_SAFE)
            assert sk == shield_scale(qd, df, Jf, np.zeros(df.shape[0]), DT, D_SAFE)
            kept = (np.zeros(0), np.zeros(0), np.zeros((0, 0)), np.zeros(1, dtype=np.int64))
            none = (*kept, np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3, 0)))  # nothing kept
            args = (DT, D_SAFE, D_I, geo.arm, geo.geom, none)
            s, k = sk
            assert exact_scale(q, qd, dc, Jc, s, k, *args) == exact_scale(
                q, qd, df, Jf, s, k, *args
            )
    assert culled_seen > 0 and filled_seen > 0  # both branches exercised


def test_the_records_of_a_pair_near_the_post_come_from_its_exact_distance() -> None:
    rng = np.random.default_rng(11)
    robot, geo = _scene(rng)
    lim = robot.limits()
    environment = np.array([k == "environment" for k in geo.kinds])
    hits = 0
    for _ in range(200):
        q = lim.q_min + (lim.q_max - lim.q_min) * rng.uniform(0.0, 1.0, robot.n)
        df, _, _, _ = measure_arm(q, geo.arm, geo.geom)
        d, _, _, _, _ = measure_culled(q, geo.arm, geo.geom, D_I)
        near = df < D_I
        assert _same(d[near], df[near])  # every pair within d_influence is computed
        hits += int(np.any(near & environment))
    assert hits > 0


def test_the_scalar_segment_distance_is_the_capsule_kernels_to_rounding() -> None:
    rng = np.random.default_rng(5)
    worst = 0.0
    for i in range(3000):
        p1, p2 = rng.normal(0.0, 0.3, 3), rng.normal(0.0, 0.3, 3)
        q1 = p1 + rng.normal(0.0, 0.2, 3) * (i % 5 != 0)  # every 5th: a point
        q2 = p2 + rng.normal(0.0, 0.2, 3) * (i % 7 != 0)
        if i % 11 == 0:  # parallel segments
            q2 = p2 + rng.uniform(-2.0, 2.0) * (q1 - p1)
        ref = capsule_capsule(p1, q1, 0.0, p2, q2, 0.0)[0]
        worst = max(worst, abs(segment_distance(p1, q1, p2, q2) - ref))
    assert worst < 1e-14  # m: far below the broad phase's margin
    assert MARGIN > 1e4 * worst


def test_the_shield_checks_measurement_is_kept_with_its_bounds_and_frames() -> None:
    rng = np.random.default_rng(3)
    robot, geo = _scene(rng)
    lim, n, P = robot.limits(), robot.n, len(geo.names)
    kept = 0
    for _ in range(60):
        q = lim.q_min + (lim.q_max - lim.q_min) * rng.uniform(0.0, 1.0, n)
        qd = rng.normal(size=n) * 0.5
        d, J, _, _, _ = measure_culled(q, geo.arm, geo.geom, D_I)
        head = (np.zeros(n), np.zeros(P), np.zeros((P, n)), np.zeros(1, dtype=np.int64))
        cache = (*head, np.zeros(P), np.zeros((n + 2, 3)), np.zeros((n + 2, 3, n)))
        exact_scale(q, qd, d, J, 1.0, -1, DT, D_SAFE, D_I, geo.arm, geo.geom, cache)
        if cache[3][0] == 0:  # no pair predicted within d_influence: nothing measured
            continue
        kept += 1
        again = measure_culled(cache[0], geo.arm, geo.geom, D_I)
        for got, want in zip(cache[1:3] + cache[4:], again, strict=True):
            assert _same(got, want)
    assert kept > 0
