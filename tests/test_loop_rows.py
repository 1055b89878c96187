"""Velocity-damper rows in the compiled campaign loop (kernels/loop_rows.py): the rows the loop
builds are those of redundancy/distance_rows.py bit for bit, the law objects decide whether a
command meets them with the loop's own kernel, and the loop's ``qp`` and ``sns`` steps, with
a secondary and with rows, are the laws' (command and flags) bit for bit: no step is handed
back to Python for its rows."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("numba", reason="the compiled campaign loop needs numba (redservo[fast])")

from redservo.campaign.loop_avoid import off_pack
from redservo.collision import Obstacle, Shape
from redservo.control.avoidance import Collision
from redservo.kernels.loop_cull import measure_culled
from redservo.kernels.loop_rows import I_ROWS, damper_rows, rows_met
from redservo.redundancy import make_law
from redservo.redundancy.distance_rows import (
    ROW_TOL,
    DistanceRows,
    bind_distances,
    distance_rows,
    given_rows,
    rows_hold,
)
from redservo.robots import make_robot
from redservo.scene import Static
from redservo.spatial import make_transform

D_SAFE, D_I, XI, DT = 0.02, 0.15, 0.3, 0.04


def _set_up(rng: np.random.Generator) -> tuple[Any, Collision, tuple[Any, ...]]:
    """The Panda among a post, a box, a ball and a floor, self pairs on; the loop's pack."""
    robot = make_robot("panda")

    def pose(t: Any) -> Static:
        return Static(make_transform(rotvec=rng.normal(0.0, 0.6, 3), t=t))

    obstacles = [
        Obstacle("post", Shape("cylinder", radius=0.03, length=1.0), pose([0.45, 0.0, 0.5])),
        Obstacle("crate", Shape("box", size=(0.3, 0.1, 0.2)), pose(rng.normal(0.3, 0.2, 3))),
        Obstacle("ball", Shape("sphere", radius=0.08), pose([0.3, 0.35, 0.5])),
        Obstacle("floor", Shape("plane"), Static(make_transform(t=[0.0, 0.0, -0.3]))),
    ]
    c = Collision(obstacles, d_safe=D_SAFE, d_influence=D_I, self_collision=True, xi=XI)
    geo = c.compiled(robot)
    assert geo is not None
    fopt = np.array([c.d_safe, c.d_influence, c.xi, c.damping, DT])
    iopt = np.zeros(I_ROWS + 1, dtype=np.int64)
    iopt[I_ROWS] = 1
    # The loop's whole pack (its types: campaign/loop_avoid.py), so that damper_rows loads the
    # warm-up's compilation instead of compiling for a shorter tuple in the test's process.
    rest = off_pack(robot.n)[5:]
    return robot, c, (True, geo.arm, geo.geom, fopt, iopt, *rest)


@pytest.mark.parametrize("seed", range(3))
def test_the_loops_rows_are_distance_rows_bit_for_bit(seed: int) -> None:
    """At random configurations (most with pairs within d_influence): the same G, b and pair
    names as the law's distance_rows, from the loop's culled measurement."""
    rng = np.random.default_rng(seed)
    robot, c, coll = _set_up(rng)
    geo = c.compiled(robot)
    assert geo is not None
    law = make_law("sns")
    bind_distances(law, c, robot)
    lim = robot.limits()
    rowed = 0
    for _ in range(40):
        q = lim.q_min + (lim.q_max - lim.q_min) * rng.uniform(0.05, 0.95, robot.n)
        d, J, _, _, _ = measure_culled(q, geo.arm, geo.geom, c.d_influence)
        G, b, pairs = damper_rows(d, J, coll)
        ref = distance_rows(law, q)
        if ref is None:
            assert b.shape == (0,) and G.shape == (0, robot.n)
            continue
        rowed += 1
        assert np.array_equal(G, ref.G) and np.array_equal(b, ref.b)
        assert tuple(geo.names[int(p)] for p in pairs) == ref.names
    assert rowed >= 10
    off = (*coll[:4], np.zeros(I_ROWS + 1, dtype=np.int64), *coll[5:])
    assert damper_rows(d, J, off)[1].shape == (0,)


def test_the_laws_decide_with_the_loops_row_test() -> None:
    """rows_hold (the laws' decision) is the loop's rows_met, by ROW_TOL exactly, and agrees
    with DistanceRows.satisfied away from the tolerance's edge."""
    rng = np.random.default_rng(4)
    for _ in range(300):
        r, n = int(rng.integers(1, 5)), 7
        G, qd = rng.normal(0.0, 0.3, (r, n)), rng.normal(0.0, 1.0, n)
        b = G @ qd + rng.normal(0.0, 1e-6, r) * rng.choice([0.0, 1.0, 1e3], r)
        rows = DistanceRows(G, b, tuple("p" * (k + 1) for k in range(r)))
        assert rows_hold(rows, qd) is rows_met(G, b, qd)
        if np.all(np.abs(G @ qd - b + ROW_TOL) > 1e-12):
            assert rows_hold(rows, qd) is rows.satisfied(qd)
    G = np.array([[0.3, -0.2, 0.1]])
    qd = np.array([0.5, 0.25, -1.0])
    g = float(G[0, 0] * qd[0] + G[0, 1] * qd[1] + G[0, 2] * qd[2])
    for gap, met in ((0.0, True), (0.5 * ROW_TOL, True), (2.0 * ROW_TOL, False)):
        assert rows_met(G, np.array([g + gap]), qd) is met
    assert rows_met(np.zeros((0, 3)), np.zeros(0), qd)


def test_given_rows_are_the_laws_rows_for_the_block_only() -> None:
    """The hand-back's rows replace the law's set-up inside the block, then it is restored."""
    robot, c, _ = _set_up(np.random.default_rng(0))
    law = make_law("qp")
    bind_distances(law, c, robot)
    rows = DistanceRows(np.ones((1, robot.n)), np.zeros(1), ("x",))
    q = robot.ready_configuration()
    before = distance_rows(law, q)
    with given_rows(law, rows):
        assert distance_rows(law, q) is rows
    with given_rows(law, None):
        assert distance_rows(law, q) is None
    after = distance_rows(law, q)
    assert (before is None and after is None) or (
        before is not None and after is not None and np.array_equal(before.b, after.b)
    )


def _sim(lam: float, dt: float, n: int) -> tuple[Any, ...]:
    """The loop's ``sim`` pack in its layout (:func:`redservo.campaign.fastloop._pack`: seven
    entries, the last "feed-forward known", False here), so that the kernels these tests call
    load the warm-up's compilation instead of compiling a six-entry one in every process."""
    return (lam, dt, 1e-3, True, np.ones(n), False, False)


def _random_step(rng: np.random.Generator, lim: Any) -> tuple[Any, ...]:
    """A loop state of the Panda with bounds often active: ``(J1, e1, q, prev, lam, dt)``."""
    n = lim.n
    J1 = np.ascontiguousarray(rng.normal(0.0, 1.0, (8, n)))
    e1 = rng.normal(0.0, 0.3, 8)
    margin = rng.uniform(0.002, 0.15, n) * lim.range
    q = np.where(rng.random(n) < 0.5, lim.q_max - margin, lim.q_min + margin)
    q = np.where(rng.random(n) < 0.5, q, lim.q_min + rng.uniform(0.2, 0.8, n) * lim.range)
    prev = rng.uniform(-0.8, 0.8, n) * lim.qdot_max
    return J1, e1, q, prev, float(rng.choice([0.3, 1.0, 5.0])), float(rng.choice([0.04, 0.08]))


def test_the_loops_qp_step_with_a_secondary_is_the_laws() -> None:
    """kernels/sensed.py ``qp_step`` with a repulsive-like secondary and no rows: the law
    object's command bit for bit and its flags, bounds active on most steps."""
    from redservo.campaign.fastloop import _flag_bits, _law_args
    from redservo.kernels.sensed import qp_step
    from redservo.redundancy.packs import limits_pack

    rng = np.random.default_rng(12)
    lim = make_robot("panda").limits(0.1)
    lp = limits_pack(lim)
    limits = (lp.rows, lp.has_v, lp.has_a, np.array(lim.q_min), np.array(lim.q_max))
    n, inside = lim.n, 0
    for opts in ({}, {"v_max": 0.3}):
        law = make_law("qp", **opts)
        args = _law_args(law, n)
        for _ in range(60):
            J1, e1, q, prev, lam, dt = _random_step(rng, lim)
            sec = rng.normal(0.0, 0.2, n)
            sim = _sim(lam, dt, n)
            none = np.zeros(0)
            qd, bits, need = qp_step(
                J1, e1, e1, False, q, prev, args, limits, sim, sec, np.zeros((0, n)), none
            )
            res = law(J1=J1, e1=e1, q=q, limits=lim, lam=lam, dt=dt, qdot_prev=prev, secondary=sec)
            assert not need
            assert np.array_equal(qd, res.qdot), opts
            assert bits == _flag_bits(res.diagnostics.events), opts
            inside += "solver: none" in " ".join(res.diagnostics.info)
    assert 0 < inside < 100


def _row_state(rng: np.random.Generator, lim: Any, r: int) -> tuple[Any, Any]:
    """Damper rows a command often breaks: ``G`` (r, n) like distance Jacobians, ``b`` from
    an approach allowed (< 0) to a push away (> 0, inside d_safe)."""
    n = lim.n
    G = np.ascontiguousarray(rng.normal(0.0, 0.3, (r, n)))
    b = rng.uniform(-0.05, 0.02, r)
    return G, b


def test_the_loops_qp_step_with_rows_is_the_laws() -> None:
    """kernels/sensed.py ``qp_step`` with damper rows (and a secondary on half the steps):
    solved in the kernel (never handed back), the law object's command with the same rows
    (given_rows) bit for bit, and its flags."""
    from redservo.campaign.fastloop import _flag_bits, _law_args
    from redservo.kernels.sensed import qp_step
    from redservo.redundancy.packs import limits_pack

    rng = np.random.default_rng(21)
    lim = make_robot("panda").limits(0.1)
    lp = limits_pack(lim)
    limits = (lp.rows, lp.has_v, lp.has_a, np.array(lim.q_min), np.array(lim.q_max))
    n, solved = lim.n, 0
    for opts in ({}, {"v_max": 0.3}):
        law = make_law("qp", **opts)
        args = _law_args(law, n)
        for k in range(80):
            J1, e1, q, prev, lam, dt = _random_step(rng, lim)
            G, b = _row_state(rng, lim, int(rng.integers(1, 5)))
            sec = rng.normal(0.0, 0.2, n) if k % 2 else np.zeros(0)
            sim = _sim(lam, dt, n)
            qd, bits, need = qp_step(J1, e1, e1, False, q, prev, args, limits, sim, sec, G, b)
            rows = DistanceRows(G, b, tuple(f"p{i}" for i in range(b.size)))
            kw = {"limits": lim, "lam": lam, "dt": dt, "qdot_prev": prev, "de1_dt": None}
            with given_rows(law, rows):
                res = law(J1=J1, e1=e1, q=q, secondary=sec if sec.size else None, **kw)
            assert not need
            assert np.array_equal(qd, res.qdot), opts
            assert bits == _flag_bits(res.diagnostics.events), opts
            solved += any("distance rows:" in i for i in res.diagnostics.info)
    assert solved > 60


def test_the_loops_sns_step_with_rows_is_the_laws() -> None:
    """kernels/sns_rows.py ``sns_row_step`` after the step kernel's command, as the loop runs
    it: where a row is broken, the law object's command with the same rows bit for bit and
    its flags; where none is, the step kernel's command is kept."""
    from redservo.campaign.fastloop import _flag_bits, _law_args
    from redservo.kernels.sensed import law_bits_sec
    from redservo.kernels.sns_rows import sns_row_step
    from redservo.redundancy.packs import limits_pack

    rng = np.random.default_rng(22)
    lim = make_robot("panda").limits(0.1)
    lp = limits_pack(lim)
    limits = (lp.rows, lp.has_v, lp.has_a, np.array(lim.q_min), np.array(lim.q_max))
    n, replaced_steps = lim.n, 0
    for opts in ({}, {"v_max": 0.3, "a_max": 2.0}):
        law = make_law("sns", **opts)
        args = _law_args(law, n)
        for k in range(80):
            J1, e1, q, prev, lam, dt = _random_step(rng, lim)
            G, b = _row_state(rng, lim, int(rng.integers(1, 5)))
            sec = rng.normal(0.0, 0.2, n) if k % 2 else np.zeros(0)
            sim = _sim(lam, dt, n)
            step = (J1, e1, e1, False, q, prev, np.zeros(n), False, args, limits, sim, sec)
            qd0, bits0, _, abort = law_bits_sec(*step)
            if abort:
                continue
            ctx = (prev, sec, args, limits, sim, G, b)
            qd, bits, replaced = sns_row_step(qd0, J1, e1, e1, False, q, *ctx)
            rows = DistanceRows(G, b, tuple(f"p{i}" for i in range(b.size)))
            kw = {"limits": lim, "lam": lam, "dt": dt, "qdot_prev": prev, "de1_dt": None}
            with given_rows(law, rows):
                res = law(J1=J1, e1=e1, q=q, secondary=sec if sec.size else None, **kw)
            assert np.array_equal(qd if replaced else qd0, res.qdot), opts
            assert (bits if replaced else bits0) == _flag_bits(res.diagnostics.events), opts
            replaced_steps += bool(replaced)
    assert replaced_steps > 40


def test_sns_row_step_reads_the_laws_option_slots() -> None:
    """The slots kernels/sns_rows.py reads sns's options from are the law's declaration."""
    from redservo.kernels import sns_rows
    from redservo.redundancy.sns import SaturationInNullSpace

    slots = SaturationInNullSpace.SLOTS
    assert slots["rcond"] == ("f", sns_rows.RCOND) and slots["margin"] == ("f", sns_rows.MARGIN)
    assert slots["shield"] == ("i", sns_rows.SHIELD)
    assert slots["has_v_max"] == ("i", sns_rows.HAS_V)
    assert slots["has_a_max"] == ("i", sns_rows.HAS_A)
    assert slots["v_max"] == ("v", sns_rows.V_MAX) and slots["a_max"] == ("v", sns_rows.A_MAX)
