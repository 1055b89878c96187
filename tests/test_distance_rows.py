"""Velocity-damper rows inside qp, sns and predictive (redservo.redundancy.distance_rows,
redservo.redundancy.sns_rows): the solvers honour the rows, and each law alone (no repulsive
secondary, no distance shield) keeps the arm off the obstacle in closed loop."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from redservo.collision import Obstacle, Shape
from redservo.experiment.build import build
from redservo.redundancy.distance_rows import DistanceRows, solve_qp_rows
from redservo.redundancy.sns import sns_solve
from redservo.redundancy.sns_rows import sns_rows_solve
from redservo.scenario import load_scenario
from redservo.scene import Static
from redservo.spatial import make_transform

_ROWS_ONLY = {"repel": False, "shield": False}
_NOTHING = {"avoid": False, "shield": False}


def _problem(seed: int) -> tuple[Any, ...]:
    rng = np.random.default_rng(seed)
    m, n, r = int(rng.integers(1, 5)), 7, int(rng.integers(1, 4))
    J, xdot = rng.normal(size=(m, n)), rng.normal(size=m)
    lo, hi = -rng.uniform(0.1, 1.0, n), rng.uniform(0.1, 1.0, n)
    G, b = 0.3 * rng.normal(size=(r, n)), -rng.uniform(0.0, 0.05, r)
    pref = 0.1 * rng.normal(size=n) if seed % 2 else None
    return J, xdot, lo, hi, G, b, pref


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**32 - 1))
@example(1710391)  # CI found it: the restored command broke every row (now scaled towards 0)
def test_sns_and_qp_rows_keep_every_row_and_joint_bound(seed: int) -> None:
    J, xdot, lo, hi, G, b, pref = _problem(seed)
    sol = sns_rows_solve(J, xdot, lo, hi, G, b, pref, 1e-10)
    assert np.all(G @ sol.qdot >= b - 1e-9)
    assert np.all((lo <= sol.qdot) & (sol.qdot <= hi))
    assert 0.0 <= sol.scale <= 1.0
    names = tuple(f"pair{k}" for k in range(b.size))
    qdot, note = solve_qp_rows(J, xdot, lo, hi, 1e-6, pref, DistanceRows(G, b, names))
    assert qdot is not None, note
    assert np.all(G @ qdot >= b - 1e-7)
    assert np.all((lo - 1e-9 <= qdot) & (qdot <= hi + 1e-9))


def test_sns_rows_without_a_binding_row_is_sns() -> None:
    J, xdot, lo, hi, G, _, _ = _problem(3)
    far = np.full(G.shape[0], -1e3)  # rows no command can break
    sol = sns_rows_solve(J, xdot, lo, hi, G, far, None, 1e-10)
    ref = sns_solve(J, xdot, lo, hi, rcond=1e-10)
    np.testing.assert_allclose(sol.qdot, ref.qdot, atol=1e-12)
    assert sol.scale == pytest.approx(ref.scale)


def _run(method: str, overrides: dict[str, Any], radius: float | None = None) -> Any:
    exp = build(load_scenario("panda-post"))
    coll = exp.options.collision
    assert coll is not None
    if radius is not None:  # a bigger ball: the predictive law's path passes through it
        ball = Obstacle(
            "ball", Shape("sphere", radius=radius), Static(make_transform(t=(0.02, 0.06, 0.74)))
        )
        coll = dataclasses.replace(coll, obstacles=(ball,))
    return exp.run(method=method, collision=dataclasses.replace(coll, **overrides))


@pytest.mark.parametrize("method", ["qp", "sns"])
def test_rows_alone_keep_d_safe_around_the_post(method: str) -> None:
    assert _run(method, _NOTHING).outcome == "collision"
    res = _run(method, _ROWS_ONLY)
    assert res.outcome == "converged"
    d = res.log.min_distance
    assert d is not None
    # The damper's ramp reaches d_safe asymptotically; first order costs micrometres.
    assert float(np.min(d)) >= 0.02 - 1e-4


def test_rows_alone_keep_the_predictive_law_off_the_ball() -> None:
    assert _run("predictive", _NOTHING, radius=0.1).outcome == "collision"
    res = _run("predictive", _ROWS_ONLY, radius=0.1)
    assert res.outcome == "converged"
    d = res.log.min_distance
    assert d is not None
    # The start is already inside d_safe (15 mm): the rows let it come no closer.
    assert float(np.min(d)) >= min(float(d[0]), 0.02) - 1e-4


def test_repel_is_a_scenario_key_and_the_predictive_fallback_gets_the_rows() -> None:
    import tomllib
    from importlib import resources

    from redservo.control.avoidance import check_collision
    from redservo.redundancy import make_law
    from redservo.scenario import parse_scenario

    text = resources.files("redservo.scenarios").joinpath("panda-post.toml").read_text()
    data = tomllib.loads(text)
    data.setdefault("collision", {})["repel"] = False
    exp = build(parse_scenario(data, "post.toml"))
    coll = exp.options.collision
    assert coll is not None and coll.repel is False and coll.avoid
    law = make_law("predictive")
    check_collision(coll, exp.robot, law)
    assert getattr(law._fallback, "_distance_source", None) is not None  # type: ignore[attr-defined]
    check_collision(None, exp.robot, law)
    assert getattr(law._fallback, "_distance_source", None) is None  # type: ignore[attr-defined]
