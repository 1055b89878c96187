"""Tests of the artificial forces of MC05 §IV-B,C (redservo.redundancy.costs)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo import ConfigurationError, JointLimits, ShapeError
from redservo.redundancy.costs import (
    joint_limit_force,
    occlusion_cost,
    occlusion_force,
    occlusion_gradient,
)
from redservo.spatial import exp_twist, inverse, rotvec_to_matrix, transform_point

SETTINGS = settings(max_examples=60, deadline=None)
seeds = st.integers(0, 2**32 - 1)


# -- helpers (independent of the code under test) --------------------------------------------


def point_interaction(x: float, y: float, Z: float) -> np.ndarray:
    """L of a 2-D point, docs/formulas.md §3.1 (ṡ = L v_c, v_c = (v, ω) in the camera frame)."""
    return np.array(
        [
            [-1.0 / Z, 0.0, x / Z, x * y, -(1.0 + x * x), y],
            [0.0, -1.0 / Z, y / Z, 1.0 + y * y, -x * y, -x],
        ]
    )


def project(X: np.ndarray) -> np.ndarray:
    return X[:2] / X[2]


def random_limits(rng: np.random.Generator, n: int) -> JointLimits:
    lo = rng.uniform(-3.0, 0.0, n)
    return JointLimits(lo, lo + rng.uniform(0.2, 4.0, n), rho=0.1)


# -- joint limits -------------------------------------------------------------------------------


@SETTINGS
@given(seed=seeds, n=st.integers(1, 8), kappa=st.floats(0.01, 50.0))
def test_joint_limit_force_is_minus_kappa_cost_gradient(seed: int, n: int, kappa: float) -> None:
    rng = np.random.default_rng(seed)
    lim = random_limits(rng, n)
    q = lim.q_min + rng.uniform(0.0, 1.0, n) * lim.range
    F = joint_limit_force(q, lim, kappa=kappa)
    assert F.shape == (n,)
    assert np.allclose(F, -kappa * lim.gradient(q), rtol=1e-12, atol=0.0)
    # Independent check: central finite differences of the cost h_s (CM01 eq. 4).
    h = 1e-6
    fd = np.array([(lim.cost(q + h * ei) - lim.cost(q - h * ei)) / (2 * h) for ei in np.eye(n)])
    assert np.allclose(F, -kappa * fd, atol=1e-6 * kappa)


def test_joint_limit_force_pushes_away_from_the_limits() -> None:
    lim = JointLimits([-1.0, -1.0, -1.0, 0.0], [1.0, 1.0, 1.0, 2.0], rho=0.1)
    q = np.array([0.95, -0.99, 0.0, 2.0])  # upper band, lower band, free, exactly at q̄_max
    F = joint_limit_force(q, lim, kappa=2.0)
    assert F[0] < 0.0 and F[1] > 0.0 and F[2] == 0.0 and F[3] < 0.0
    # A small step along the force reduces the cost and increases every band axis's distance.
    q2 = q + 1e-3 * F
    assert lim.cost(q2) < lim.cost(q)
    band = lim.in_band(q)
    assert np.all(lim.distance(q2)[band] > lim.distance(q)[band])
    # Value: e2 = s / Δq, s = 0.95 - 0.8 = 0.15, Δq = 2.
    assert F[0] == pytest.approx(-2.0 * 0.15 / 2.0)


def test_joint_limit_force_bad_input() -> None:
    lim = JointLimits([-1.0, -1.0], [1.0, 1.0])
    with pytest.raises(ConfigurationError, match="kappa"):
        joint_limit_force([0.0, 0.0], lim, kappa=0.0)
    with pytest.raises(ConfigurationError, match="kappa"):
        joint_limit_force([0.0, 0.0], lim, kappa=float("nan"))
    with pytest.raises(ShapeError, match="q"):
        joint_limit_force([0.0, 0.0, 0.0], lim)
    with pytest.raises(ShapeError, match="finite"):
        joint_limit_force([0.0, np.inf], lim)


# -- occlusion cost -----------------------------------------------------------------------------


@SETTINGS
@given(
    pa=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),
    pt=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),
    beta=st.floats(0.5, 200.0),
)
def test_occlusion_cost_and_gradient_by_finite_differences(pa, pt, beta) -> None:
    pa_ = np.array(pa)
    pt_ = np.array(pt)

    def V(p: np.ndarray) -> float:
        return occlusion_cost(float(np.linalg.norm(p - pt_)), beta=beta)

    d = float(np.linalg.norm(pa_ - pt_))
    assert V(pa_) == pytest.approx(np.exp(-beta * d * d), rel=1e-12)
    g = occlusion_gradient(pa_, pt_, beta=beta)
    h = 1e-6
    fd = np.array([(V(pa_ + h * ei) - V(pa_ - h * ei)) / (2 * h) for ei in np.eye(2)])
    assert np.allclose(g, fd, atol=1e-7 * (1.0 + beta))


def test_occlusion_cost_values() -> None:
    assert occlusion_cost(0.0, beta=3.0) == 1.0
    assert occlusion_cost(0.5, beta=4.0) == pytest.approx(np.exp(-1.0))
    assert occlusion_cost(10.0, beta=100.0) == 0.0  # underflows cleanly, no NaN


# -- occlusion force ----------------------------------------------------------------------------


def _random_scene(rng: np.random.Generator):
    """A camera at wMc, a target point and an occluder point in front of it (world frame)."""
    wMc = np.eye(4)
    wMc[:3, :3] = rotvec_to_matrix(rng.normal(scale=0.3, size=3))
    wMc[:3, 3] = rng.normal(scale=0.2, size=3)
    cMw = inverse(wMc)
    Xt_c = np.array([*rng.uniform(-0.2, 0.2, 2), 1.0]) * rng.uniform(0.8, 1.5)
    Xa_c = np.array([*(project(Xt_c) + rng.uniform(-0.1, 0.1, 2)), 1.0]) * rng.uniform(0.3, 0.7)
    Xt_w = transform_point(wMc, Xt_c)
    Xa_w = transform_point(wMc, Xa_c)
    return wMc, cMw, Xt_w, Xa_w


def test_point_interaction_helper_matches_real_motion() -> None:
    # The test helper itself is checked against a real camera motion.
    rng = np.random.default_rng(1)
    X = np.array([0.1, -0.2, 0.8])
    L = point_interaction(*project(X), X[2])
    for _ in range(5):
        v = rng.normal(size=6)
        h = 1e-6
        Xp = transform_point(inverse(exp_twist(v, h)), X)
        Xm = transform_point(inverse(exp_twist(v, -h)), X)
        assert np.allclose((project(Xp) - project(Xm)) / (2 * h), L @ v, atol=1e-6)


@SETTINGS
@given(seed=seeds, n=st.integers(2, 8), beta=st.floats(1.0, 300.0))
def test_a_step_along_the_force_increases_the_image_distance(seed: int, n: int, beta) -> None:
    """Real camera motion: v_c = J q̇ with q̇ = F, re-project the occluder, d must grow."""
    rng = np.random.default_rng(seed)
    wMc, cMw, Xt_w, Xa_w = _random_scene(rng)
    Xa_c = transform_point(cMw, Xa_w)
    pa = project(Xa_c)
    pt = project(transform_point(cMw, Xt_w))  # the target point, held fixed as in eq. 31
    L = point_interaction(pa[0], pa[1], Xa_c[2])
    J = rng.normal(size=(6, n))
    res = occlusion_force(pa, pt, L @ J, beta=beta)
    assert np.isfinite(res.force).all()
    assert res.distance == pytest.approx(np.linalg.norm(pa - pt))
    assert res.cost == pytest.approx(np.exp(-beta * res.distance**2))
    # H has rank 2 for a generic J, so the image point moves straight away: H F = -∇V.
    assert np.allclose(
        L @ J @ res.force, -res.gradient, atol=1e-9 * (1 + np.abs(res.gradient).max())
    )
    # Same force through the (L_pa, J) form.
    res2 = occlusion_force(pa, pt, L, J=J, beta=beta)
    assert np.allclose(res2.force, res.force)
    if res.distance < 1e-9 or np.linalg.norm(res.gradient) < 1e-12:
        return  # no direction to escape along (d = 0) or the cost is flat (V underflows)
    # Real motion: a small step q̇ dt moves the camera by exp(J q̇ dt).
    step = 1e-4 / np.linalg.norm(J @ res.force)
    wMc_new = wMc @ exp_twist(J @ res.force, step)
    pa_new = project(transform_point(inverse(wMc_new), Xa_w))
    d_new = np.linalg.norm(pa_new - pt)
    assert d_new > res.distance
    # ...and the increase matches the linear model to first order.
    rate = -(pa - pt) @ res.gradient / res.distance
    assert d_new - res.distance == pytest.approx(rate * step, rel=1e-2)


def test_occlusion_force_with_a_single_joint_still_increases_distance() -> None:
    # H of rank 1 (n = 1): the force is the least-squares escape, dV/dt <= 0 still.
    pa, pt = np.array([0.05, 0.02]), np.array([0.0, 0.0])
    H = np.array([[1.0], [0.3]])
    res = occlusion_force(pa, pt, H, beta=50.0)
    pa_new = pa + 1e-4 * (H @ res.force)
    assert np.linalg.norm(pa_new - pt) > res.distance


def test_occlusion_force_at_zero_distance_is_zero_and_finite() -> None:
    H = np.random.default_rng(2).normal(size=(2, 6))
    res = occlusion_force([0.1, 0.1], [0.1, 0.1], H, beta=10.0)
    assert res.distance == 0.0 and res.cost == 1.0
    assert np.array_equal(res.force, np.zeros(6))
    # A zero interaction matrix (point not moving with q) gives a zero force, not NaN.
    res0 = occlusion_force([0.2, 0.1], [0.1, 0.1], np.zeros((2, 3)), beta=10.0)
    assert np.array_equal(res0.force, np.zeros(3))


def test_occlusion_bad_input() -> None:
    H = np.zeros((2, 6))
    for beta in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ConfigurationError, match="beta"):
            occlusion_force([0.0, 0.0], [0.1, 0.0], H, beta=beta)
        with pytest.raises(ConfigurationError, match="beta"):
            occlusion_cost(0.1, beta=beta)
    with pytest.raises(ShapeError, match="p_occluder"):
        occlusion_force([0.0, 0.0, 1.0], [0.1, 0.0], H, beta=1.0)
    with pytest.raises(ShapeError, match="p_target"):
        occlusion_force([0.0, 0.0], [np.nan, 0.0], H, beta=1.0)
    with pytest.raises(ShapeError, match="H"):
        occlusion_force([0.0, 0.0], [0.1, 0.0], np.zeros((3, 6)), beta=1.0)
    with pytest.raises(ShapeError, match="H"):
        occlusion_force([0.0, 0.0], [0.1, 0.0], np.zeros((2, 5)), J=np.zeros((6, 5)), beta=1.0)
    with pytest.raises(ShapeError, match="J"):
        occlusion_force([0.0, 0.0], [0.1, 0.0], np.zeros((2, 6)), J=np.zeros((5, 5)), beta=1.0)
    with pytest.raises(ShapeError, match="column"):
        occlusion_force([0.0, 0.0], [0.1, 0.0], np.zeros((2, 0)), beta=1.0)
    with pytest.raises(ConfigurationError, match="rcond"):
        occlusion_force([0.0, 0.0], [0.1, 0.0], H, beta=1.0, rcond=0.0)
    with pytest.raises(ShapeError, match="d"):
        occlusion_cost(-0.1, beta=1.0)
