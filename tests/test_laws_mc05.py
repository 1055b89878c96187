"""Tests of the directional-redundancy law of Mansard & Chaumette 2005 (MC05 eqs. 9-23)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import redservo
from redservo import ConfigurationError, JointLimits, ShapeError, make_law
from redservo.redundancy.directional import directional_projection
from redservo.redundancy.linalg import DEFAULT_RCOND
from tests.laws import paper_law

SETTINGS = settings(max_examples=80, deadline=None)
seeds = st.integers(0, 2**32 - 1)
JACOBIAN_KINDS = ("generic", "square", "deficient", "tiny-sigma", "small-sigma", "zero", "tall")


def orthogonal(rng: np.random.Generator, n: int) -> np.ndarray:
    Q, R = np.linalg.qr(rng.normal(size=(n, n)))
    return Q * np.sign(np.diag(R))


def make_jacobian(rng: np.random.Generator, kind: str, n: int) -> np.ndarray:
    """A (m, n) task Jacobian of the given kind (m <= n except for 'tall')."""
    m = {"square": n, "tall": n + int(rng.integers(1, 3))}.get(kind, int(rng.integers(1, n + 1)))
    if kind in ("generic", "square", "tall"):
        return rng.normal(size=(m, n))
    if kind == "deficient":  # rank r < min(m, n) (or r = 0)
        r = int(rng.integers(0, min(m, n)))
        return rng.normal(size=(m, r)) @ rng.normal(size=(r, n))
    if kind == "zero":
        return np.zeros((m, n))
    k = min(m, n)
    sigma = rng.uniform(0.5, 5.0, k)
    # one singular value below rcond * σ_max (counted as zero) or just above it
    sigma[-1] = 1e-11 if kind == "tiny-sigma" else 1e-6
    S = np.zeros((m, n))
    S[:k, :k] = np.diag(sigma)
    return orthogonal(rng, m) @ S @ orthogonal(rng, n).T


@dataclass
class Problem:
    J1: np.ndarray
    e1: np.ndarray
    q: np.ndarray
    limits: JointLimits
    secondary: np.ndarray
    lam: float
    dt: float


@st.composite
def problems(draw: st.DrawFn, kinds: tuple[str, ...] = JACOBIAN_KINDS) -> Problem:
    n = draw(st.integers(1, 7))
    kind = draw(st.sampled_from(kinds))
    rng = np.random.default_rng(draw(seeds))
    J1 = make_jacobian(rng, kind, n)
    m = J1.shape[0]
    e1 = draw(hnp.arrays(float, m, elements=st.floats(-2.0, 2.0)))
    lo = rng.uniform(-3.0, 0.0, n)
    limits = JointLimits(lo, lo + rng.uniform(0.2, 4.0, n), rho=0.1)
    frac = draw(hnp.arrays(float, n, elements=st.floats(0.0, 1.0)))  # 0 and 1: at a limit
    q = np.clip(limits.q_min + frac * limits.range, limits.q_min, limits.q_max)
    secondary = draw(hnp.arrays(float, n, elements=st.floats(-20.0, 20.0)))
    lam = draw(st.floats(0.05, 3.0))
    dt = draw(st.floats(0.001, 0.2))
    return Problem(J1, e1, q, limits, secondary, lam, dt)


def leakage(J1: np.ndarray, z: np.ndarray) -> float:
    """Bound on the task motion along singular values counted as zero (rank loss)."""
    _, s, Vt = np.linalg.svd(J1)
    if s.size == 0 or s[0] == 0.0:
        return 0.0
    small = s <= DEFAULT_RCOND * s[0]
    return float(np.sum(s[small] * np.abs((Vt @ z)[: s.size][small])))


def rounding_tol(J1: np.ndarray, *vectors: np.ndarray) -> float:
    smax = float(np.linalg.norm(J1, 2)) if J1.size else 0.0
    return 1e-11 * (1.0 + sum(float(np.linalg.norm(v)) for v in vectors)) * (1.0 + smax)


# -- MC05 eq. 9: the step never makes the predicted task error worse ---------------------------


@SETTINGS
@given(
    pb=problems(),
    kappa=st.floats(0.01, 100.0),
    margin=st.floats(0.05, 1.0),
    use_jl=st.booleans(),
)
def test_eq9_error_never_worse_than_classical(pb: Problem, kappa, margin, use_jl) -> None:
    law = paper_law("directional", kappa=kappa, margin=margin, use_joint_limits=use_jl)
    kw = dict(J1=pb.J1, e1=pb.e1, q=pb.q, limits=pb.limits, lam=pb.lam, dt=pb.dt)
    res = law(**kw, secondary=pb.secondary)
    cl = paper_law("classical")(**kw)
    assert res.qdot.shape == (pb.J1.shape[1],) and np.isfinite(res.qdot).all()
    after = np.linalg.norm(pb.e1 + pb.J1 @ res.qdot * pb.dt)
    classical = np.linalg.norm(pb.e1 + pb.J1 @ cl.qdot * pb.dt)
    z = pb.dt * (pb.secondary - (kappa * pb.limits.gradient(pb.q) if use_jl else 0.0))
    tol = leakage(pb.J1, z) + rounding_tol(pb.J1, pb.e1, res.qdot * pb.dt, cl.qdot * pb.dt)
    assert after <= classical + tol
    if res.diagnostics.task_rank == pb.J1.shape[0]:  # full row rank: MC05 eq. 9 literally
        assert after <= abs(1.0 - pb.lam * pb.dt) * np.linalg.norm(pb.e1) + tol


@SETTINGS
@given(pb=problems(), ff=st.data())
def test_eq9_with_feed_forward(pb: Problem, ff: st.DataObject) -> None:
    m = pb.J1.shape[0]
    de1_dt = ff.draw(hnp.arrays(float, m, elements=st.floats(-3.0, 3.0)))
    kw = dict(J1=pb.J1, e1=pb.e1, q=pb.q, limits=pb.limits, lam=pb.lam, dt=pb.dt, de1_dt=de1_dt)
    res = paper_law("directional", kappa=5.0)(**kw, secondary=pb.secondary)
    cl = paper_law("classical")(**kw)
    # ė1 = J1 q̇ + ∂e1/∂t: the predicted error includes the target's motion.
    drift = pb.e1 + pb.dt * de1_dt
    after = np.linalg.norm(drift + pb.J1 @ res.qdot * pb.dt)
    classical = np.linalg.norm(drift + pb.J1 @ cl.qdot * pb.dt)
    z = pb.dt * (pb.secondary - 5.0 * pb.limits.gradient(pb.q))
    tol = leakage(pb.J1, z) + rounding_tol(pb.J1, drift, res.qdot * pb.dt, cl.qdot * pb.dt)
    assert after <= classical + tol


# -- the pure projection ------------------------------------------------------------------------


@st.composite
def svd_problems(draw: st.DrawFn):
    n = draw(st.integers(1, 7))
    m = draw(st.integers(1, 8))
    r = draw(st.integers(0, min(m, n)))
    rng = np.random.default_rng(draw(seeds))
    U, V = orthogonal(rng, m), orthogonal(rng, n)
    sigma = np.zeros(min(m, n))
    sigma[:r] = np.sort(rng.uniform(1e-3, 10.0, r))[::-1]
    vec = st.floats(-10.0, 10.0)
    e = draw(hnp.arrays(float, m, elements=vec))
    de = draw(hnp.arrays(float, m, elements=vec))
    z = draw(hnp.arrays(float, n, elements=vec))
    return U, sigma, V, r, e, de, z


def jacobian_from_svd(U, sigma, V) -> np.ndarray:
    S = np.zeros((U.shape[0], V.shape[0]))
    S[: sigma.size, : sigma.size] = np.diag(sigma)
    return U @ S @ V.T


@SETTINGS
@given(prob=svd_problems(), margin=st.floats(0.01, 1.0))
def test_projection_never_increases_the_error(prob, margin) -> None:
    U, sigma, V, r, e, de, z = prob
    res = directional_projection(U, sigma, V, r, e, de, z, margin=margin)
    J = jacobian_from_svd(U, sigma, V)
    tol = 1e-9 * (1.0 + np.abs(e).sum() + np.abs(de).sum() + 10.0 * np.abs(z).sum())
    assert np.linalg.norm(e + de + J @ res.dq2) <= np.linalg.norm(e + de) + tol
    a = U[:, :r].T @ (e + de)
    y = sigma[:r] * (V.T @ res.dq2)[:r]
    assert np.all(np.abs(a + y) <= np.abs(a) + tol)  # componentwise (eq. 18)
    assert np.all(np.abs(y) <= 2.0 * margin * np.abs(a) + tol)  # within the margin
    # P_z: diagonal p in [0, 1] (proof in the module docstring), symmetric, eigenvalues p.
    assert np.all((res.p >= 0.0) & (res.p <= 1.0))
    assert np.all(res.p[r:] == 1.0)
    assert np.allclose(res.P, res.P.T, atol=1e-12)
    assert np.allclose(np.linalg.eigvalsh(res.P), np.sort(res.p), atol=1e-9)
    assert np.allclose(res.P @ z, res.dq2, atol=1e-9 * (1.0 + np.abs(z).sum()))
    n = V.shape[0]
    assert n - r <= res.rank <= n


def literal_eq20(a: float, s: float, zt: float) -> float:
    """MC05 eq. 20 as a case table (sign corrected, docs/formulas.md §8); independent oracle."""
    y = s * zt
    lo, hi = sorted((0.0, -2.0 * a))
    if lo <= y <= hi:
        return zt
    if (y > 0.0 and a > 0.0) or (y < 0.0 and a < 0.0):
        return 0.0
    return -2.0 * a / s


@SETTINGS
@given(prob=svd_problems())
def test_projection_matches_the_case_table_of_eq20(prob) -> None:
    U, sigma, V, r, e, de, z = prob
    res = directional_projection(U, sigma, V, r, e, de, z)
    a = U.T @ (e + de)
    zt = V.T @ z
    expected = zt.copy()
    for i in range(r):
        expected[i] = literal_eq20(a[i], sigma[i], zt[i])
    assert np.allclose(V.T @ res.dq2, expected, atol=1e-9 * (1.0 + np.abs(zt).max(initial=0.0)))


def test_projection_by_hand_one_dof() -> None:
    """J = [2], e + de = 0.9: the three cases of eq. 20 with hand-computed values."""
    one = np.eye(1)
    args = (one, np.array([2.0]), one, 1, np.array([1.0]), np.array([-0.1]))
    # σ z̃ = +1 has the sign of a = 0.9: it would increase |e|, blocked.
    r = directional_projection(*args, np.array([0.5]))
    assert r.dq2[0] == 0.0 and r.p[0] == 0.0 and r.rank == 0
    # σ z̃ = -1 lies in [-1.8, 0]: kept; the error becomes -0.1.
    r = directional_projection(*args, np.array([-0.5]))
    assert r.dq2[0] == -0.5 and r.p[0] == 1.0
    # σ z̃ = -10 overshoots: clipped to -1.8 / σ = -0.9; the error becomes -0.9 (|.| unchanged).
    r = directional_projection(*args, np.array([-5.0]))
    assert r.dq2[0] == pytest.approx(-0.9) and r.p[0] == pytest.approx(0.18)
    # margin 1/2: clipped to -0.9 / σ; the error becomes exactly 0.
    r = directional_projection(*args, np.array([-5.0]), margin=0.5)
    assert 0.9 + 2.0 * r.dq2[0] == pytest.approx(0.0, abs=1e-15)


def test_projection_bad_input() -> None:
    I2 = np.eye(2)
    ok = (I2, np.ones(2), I2, 2, np.zeros(2), np.zeros(2), np.zeros(2))
    with pytest.raises(ConfigurationError, match="margin"):
        directional_projection(*ok, margin=0.0)
    with pytest.raises(ConfigurationError, match="margin"):
        directional_projection(*ok, margin=1.5)
    with pytest.raises(ShapeError, match="rank"):
        directional_projection(I2, np.ones(2), I2, 3, np.zeros(2), np.zeros(2), np.zeros(2))
    with pytest.raises(ShapeError, match="z"):
        directional_projection(I2, np.ones(2), I2, 2, np.zeros(2), np.zeros(2), np.zeros(3))
    with pytest.raises(ShapeError, match="V"):
        directional_projection(I2, np.ones(2), np.ones((2, 3)), 2, *ok[4:])
    with pytest.raises(ShapeError, match="finite"):
        directional_projection(I2, np.ones(2), I2, 2, np.array([np.nan, 0.0]), *ok[5:])


# -- reduction to the classical projector when e1 = 0 -------------------------------------------


@SETTINGS
@given(pb=problems(), use_jl=st.booleans())
def test_zero_error_reduces_to_the_classical_null_space_projector(pb: Problem, use_jl) -> None:
    e0 = np.zeros(pb.J1.shape[0])
    kw = dict(J1=pb.J1, e1=e0, q=pb.q, limits=pb.limits, lam=pb.lam, dt=pb.dt)
    res = paper_law("directional", kappa=3.0, use_joint_limits=use_jl)(**kw, secondary=pb.secondary)
    force = pb.secondary - (3.0 * pb.limits.gradient(pb.q) if use_jl else 0.0)
    cl = paper_law("classical")(**kw, secondary=force)  # q̇ = J1^⊥ force
    assert np.allclose(res.qdot, cl.qdot, atol=1e-9 * (1.0 + np.abs(force).sum()))
    n = pb.J1.shape[1]
    if res.diagnostics.task_rank == n:  # e.g. m = n full rank: nothing moves
        assert np.allclose(res.qdot, 0.0, atol=1e-9 * (1.0 + np.abs(force).sum()))
    # Independent projector for well-conditioned J1.
    s = np.linalg.svd(pb.J1, compute_uv=False)
    if s.size and s[-1] > 1e-3 * s[0]:
        Jp = np.linalg.pinv(pb.J1)
        assert np.allclose(
            res.qdot, (np.eye(n) - Jp @ pb.J1) @ force, atol=1e-8 * (1 + np.abs(force).sum())
        )


# -- MC05 experiment 1: a full-rank square task still lets the secondary act --------------------


def _square_problem(seed: int, n: int = 6):
    rng = np.random.default_rng(seed)
    J = orthogonal(rng, n) @ np.diag(rng.uniform(0.5, 2.0, n)) @ orthogonal(rng, n).T
    limits = JointLimits(-np.ones(n), np.ones(n), rho=0.1)
    q = rng.uniform(-0.5, 0.5, n)
    q[0] = 0.95  # axis 0 deep in its upper band
    q[n - 1] = -0.9  # last axis in its lower band
    return J, limits, q


@settings(max_examples=30, deadline=None)
@given(seed=seeds, c=st.floats(0.1, 5.0))
def test_full_rank_square_task_moves_along_a_helping_force(seed: int, c: float) -> None:
    J, limits, q = _square_problem(seed)
    lam, dt, kappa = 0.5, 0.04, 2.0
    e2 = limits.gradient(q)
    e1 = c * J @ e2  # the force -κ e2 drives the task error toward 0: it helps
    res = paper_law("directional", kappa=kappa)(J1=J, e1=e1, q=q, limits=limits, lam=lam, dt=dt)
    assert res.diagnostics.projector_rank > 0
    # In this configuration J z = -κ dt e1 / c is along -e1, so y_i = -(κ dt / c) a_i / (1 - λ dt):
    # kept whole while κ dt / c <= 2 (1 - λ dt), else clipped; never blocked.
    qdot_cl = -lam * np.linalg.solve(J, e1)
    moved = res.qdot - qdot_cl
    z = -kappa * e2
    assert moved @ z > 0.0  # the robot moves along the force
    assert res.qdot[0] < qdot_cl[0] and res.qdot[-1] > qdot_cl[-1]  # away from both limits
    if kappa * dt / c <= 2.0 * (1.0 - lam * dt):
        assert np.allclose(moved, z, atol=1e-9)
        assert res.diagnostics.projector_rank == 6
    # and the task error still decreases at least as fast as the classical law's
    assert np.linalg.norm(e1 + J @ res.qdot * dt) <= (1 - lam * dt) * np.linalg.norm(e1) + 1e-9


@settings(max_examples=30, deadline=None)
@given(seed=seeds, c=st.floats(0.1, 5.0))
def test_full_rank_square_task_blocks_a_hindering_force(seed: int, c: float) -> None:
    J, limits, q = _square_problem(seed)
    lam, dt = 0.5, 0.04
    e1 = -c * J @ limits.gradient(q)  # now the force would increase every error component
    res = paper_law("directional", kappa=2.0)(J1=J, e1=e1, q=q, limits=limits, lam=lam, dt=dt)
    assert np.allclose(res.qdot, -lam * np.linalg.solve(J, e1), atol=1e-9)
    # Only the components with z̃_i = 0 (none here, generically) keep p_i = 1.
    assert res.diagnostics.projector_rank == 0


# -- P_z in the law; degenerate inputs ---------------------------------------------------------


@SETTINGS
@given(pb=problems())
def test_projector_rank_between_null_space_and_n(pb: Problem) -> None:
    res = paper_law("directional")(
        J1=pb.J1, e1=pb.e1, q=pb.q, limits=pb.limits, lam=pb.lam, dt=pb.dt, secondary=pb.secondary
    )
    d = res.diagnostics
    m, n = pb.J1.shape
    assert d.method == "directional"
    assert n - d.task_rank <= d.projector_rank <= n
    assert d.rank_deficient == (d.task_rank < m)


@pytest.mark.parametrize(
    "J1",
    [
        np.zeros((2, 4)),  # rank 0
        np.array([[1.0, 2.0, 0.0], [2.0, 4.0, 0.0]]),  # rank 1 < m
        np.diag([1.0, 1e-12, 1.0]),  # tiny σ counted as zero
        np.diag([1.0, 1e-7, 1.0]),  # small σ kept
        1e-200 * np.ones((1, 3)),  # absolutely tiny J
        np.eye(3),
    ],
)
@pytest.mark.parametrize("e_scale", [0.0, 1.0])
@pytest.mark.parametrize("secondary", [None, np.array([0.0, 0.0, 0.0]), np.array([1.0, -2.0, 3.0])])
def test_degenerate_inputs_stay_finite(J1, e_scale, secondary) -> None:
    m, n = J1.shape
    limits = JointLimits(-np.ones(n), np.ones(n))
    q = np.array([1.0, -1.0, 0.0, 0.95][:n])  # two axes exactly at a limit
    sec = None if secondary is None else np.resize(secondary, n)
    res = paper_law("directional")(
        J1=J1, e1=e_scale * np.ones(m), q=q, limits=limits, lam=0.5, dt=0.04, secondary=sec
    )
    assert res.qdot.shape == (n,) and np.isfinite(res.qdot).all()
    assert not any("non-finite" in note for note in res.diagnostics.notes)
    if e_scale == 0.0:
        # no task error: only the null-space part of the force moves the robot
        assert np.all(np.abs(J1 @ res.qdot) <= 1e-6 * (1 + np.abs(res.qdot).sum()))


def test_zero_error_zero_force_gives_zero_velocity() -> None:
    limits = JointLimits(-np.ones(4), np.ones(4))
    J1 = np.random.default_rng(3).normal(size=(2, 4))
    res = paper_law("directional")(
        J1=J1, e1=np.zeros(2), q=np.zeros(4), limits=limits, lam=1, dt=0.1
    )
    assert np.array_equal(res.qdot, np.zeros(4))
    assert "no secondary command (z = 0)" in res.diagnostics.notes
    # Fig. 3 count: the n - m = 2 null-space directions; no task direction is used by z = 0.
    assert res.diagnostics.projector_rank == 2


def test_fig3_rank_counts_only_directions_the_force_uses() -> None:
    """Full-rank square task: rank 0 with no force, > 0 once a helping force acts (MC05 Fig. 3)."""
    limits = JointLimits(-np.ones(2), np.ones(2))
    law = paper_law("directional", kappa=5.0)
    J1 = np.eye(2)
    far = law(J1=J1, e1=np.array([0.5, 0.0]), q=np.zeros(2), limits=limits, lam=1, dt=0.1)
    assert far.diagnostics.projector_rank == 0
    # Axis 0 deep in its upper band while the task asks it to decrease: the force helps.
    near = law(
        J1=J1, e1=np.array([0.5, 0.0]), q=np.array([0.95, 0.0]), limits=limits, lam=1, dt=0.1
    )
    assert near.diagnostics.projector_rank == 1


def test_rank_deficiency_is_reported() -> None:
    limits = JointLimits(-np.ones(3), np.ones(3))
    J1 = np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    res = paper_law("directional")(
        J1=J1, e1=np.array([1.0, 0.0]), q=np.array([0.95, 0.0, 0.0]), limits=limits, lam=1, dt=0.1
    )
    assert res.diagnostics.rank_deficient and res.diagnostics.task_rank == 1
    assert any("rank 1 < m = 2" in note for note in res.diagnostics.notes)


def test_use_joint_limits_switch() -> None:
    J1 = np.array([[1.0, 1.0, 0.0]])
    limits = JointLimits(-np.ones(3), np.ones(3))
    q = np.array([0.95, 0.0, -0.99])
    kw = dict(J1=J1, e1=np.zeros(1), q=q, limits=limits, lam=1.0, dt=0.1)
    off = paper_law("directional", use_joint_limits=False)(**kw)
    assert np.array_equal(off.qdot, np.zeros(3))
    on = paper_law("directional", kappa=2.0)(**kw)
    assert on.qdot[0] < 0.0 and on.qdot[2] > 0.0  # away from both limits, in Ker J1


def test_registered_and_options_validated() -> None:
    assert "directional" in redservo.METHODS
    for bad in ({"kappa": 0.0}, {"kappa": -1.0}, {"kappa": float("inf")}, {"margin": 0.0}):
        with pytest.raises(ConfigurationError):
            make_law("directional", **bad)
    with pytest.raises(ConfigurationError, match="margin"):
        make_law("directional", margin=1.01)
    with pytest.raises(ConfigurationError, match="use_joint_limits"):
        make_law("directional", use_joint_limits="yes")
    with pytest.raises(ConfigurationError, match="no option"):
        make_law("directional", alpha=1.0)
    law = make_law("directional", kappa=0.5, margin=0.8)
    assert "kappa=0.5" in repr(law) and "margin=0.8" in repr(law)
