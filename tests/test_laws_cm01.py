"""Property tests of the CM01 laws: gpm, gpm-auto and the iterative family (eqs. 1-21).

The expected values come from an independent reference written here with
``numpy.linalg.pinv`` of stacked constraints (the "task priority" reading of
docs/formulas.md §7.4: each level is the minimum-norm change of the previous command
that keeps ``J1 q̇`` and the earlier constrained axes and sets the new ones to
``(1 - γ_k)`` times their previous velocity), not from the laws' own output.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.linalg import null_space

from redservo import ConfigurationError, JointLimits, make_law
from redservo.redundancy.base import LawResult
from tests.laws import paper_law

NULL_METHODS = (
    "gpm",
    "gpm-auto",
    "iterative-basic",
    "iterative",
    "iterative-smooth",
    "iterative-smooth-e2",
)
ITERATIVE = ("iterative-basic", "iterative", "iterative-smooth", "iterative-smooth-e2")
SETTINGS = settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.filter_too_much]
)
REGIONS = ("mid", "mid", "low_band", "high_band", "low_tilde", "high_tilde", "low_bar", "high_bar")


class Problem(NamedTuple):
    J1: np.ndarray
    e1: np.ndarray
    q: np.ndarray
    limits: JointLimits
    lam: float
    dt: float

    def run(self, method: str, **kw: object) -> LawResult:
        opts = kw.pop("options", {})
        law = paper_law(method, **opts)  # type: ignore[arg-type]
        return law(
            J1=self.J1,
            e1=self.e1,
            q=self.q,
            limits=self.limits,
            lam=self.lam,
            dt=self.dt,
            **kw,  # type: ignore[arg-type]
        )


def _q_in(region: str, lim: JointLimits, i: int, rng: np.random.Generator) -> float:
    lo, hi = lim.q_min[i], lim.q_max[i]
    tlo, thi = lim.q_tilde_min[i], lim.q_tilde_max[i]
    return {
        "mid": lambda: rng.uniform(tlo, thi),
        "low_band": lambda: rng.uniform(lo, tlo),
        "high_band": lambda: rng.uniform(thi, hi),
        "low_tilde": lambda: tlo,
        "high_tilde": lambda: thi,
        "low_bar": lambda: lo,
        "high_bar": lambda: hi,
    }[region]()


@st.composite
def problems(draw: st.DrawFn, *, max_n: int = 9) -> Problem:
    """A random well-conditioned full-row-rank J1 (m < n) and q anywhere within the limits.

    Joints are drawn in the middle, inside the bands, or exactly at a threshold or
    a limit; the continuous values come from a seeded generator.
    """
    n = draw(st.integers(3, max_n))
    m = draw(st.integers(1, n - 1))
    regions = draw(st.lists(st.sampled_from(REGIONS), min_size=n, max_size=n))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    J1 = rng.normal(size=(m, n))
    sv = np.linalg.svd(J1, compute_uv=False)
    assume(sv[-1] > 1e-2 * sv[0])
    q_min = rng.uniform(-2.0, 0.5, n)
    lim = JointLimits(q_min, q_min + rng.uniform(0.2, 3.0, n), rho=rng.uniform(0.05, 0.3))
    q = np.array([_q_in(r, lim, i, rng) for i, r in enumerate(regions)])
    e1 = rng.normal(size=m) * rng.uniform(0.05, 2.0)
    return Problem(J1, e1, q, lim, float(rng.uniform(0.1, 2.0)), float(rng.uniform(0.005, 0.3)))


def tol(*arrays: np.ndarray) -> float:
    """Absolute tolerance 1e-9 scaled by the magnitude of the quantities compared."""
    return 1e-9 * (1.0 + max(float(np.abs(a).max(initial=0.0)) for a in arrays))


# -- independent reference ---------------------------------------------------------------------


class Reference(NamedTuple):
    qdot: np.ndarray
    levels: tuple[tuple[int, ...], ...]
    gamma: np.ndarray
    consistent: bool  # every level's constraints were exactly satisfiable (well conditioned)


def reference_iterative(
    p: Problem,
    *,
    smooth: bool,
    alpha: float = 0.0,
    max_levels: int = 100,
    de1_dt: np.ndarray | None = None,
    secondary: np.ndarray | None = None,
) -> Reference:
    """CM01 §III with stacked pinv's: q̇_j = q̇_{j-1} + A⁺(target - A q̇_{j-1}), A = [J1; S_C]."""
    n = p.q.shape[0]
    Jp = np.linalg.pinv(p.J1)
    P = np.eye(n) - Jp @ p.J1
    e = p.e1 if de1_dt is None else p.e1 + de1_dt / p.lam
    x = -p.lam * Jp @ e
    if secondary is not None:
        x = x + P @ secondary
    e2_term = -p.lam * alpha * P @ p.limits.gradient(p.q)
    C: list[int] = []
    levels: list[tuple[int, ...]] = []
    gamma = np.zeros(n)
    consistent = True
    for level in range(max_levels):
        q_hat = p.q + p.dt * x
        crit = np.flatnonzero(p.limits.critical(p.q, q_hat))
        K = [int(k) for k in crit if k not in C]
        if not K:
            break
        g = p.limits.gamma(q_hat)[K] if smooth else np.ones(len(K))
        A = np.vstack([p.J1, np.eye(n)[C + K]])
        target = np.concatenate([p.J1 @ x, x[C], (1.0 - g) * x[K]])
        if (
            np.linalg.svd(np.eye(n)[C + K] @ null_space(p.J1), compute_uv=False).min(initial=1.0)
            < 1e-3
            or len(C + K) > n - p.J1.shape[0]
        ):
            consistent = False
        x = x + np.linalg.pinv(A) @ (target - A @ x)
        if level == 0:
            x = x + e2_term  # eq. 20: the e2 term is added after the unchanged level-1 system
        C += K
        gamma[K] = g
        levels.append(tuple(K))
    if not levels:
        x = x + e2_term
    return Reference(x, tuple(levels), gamma, consistent)


# -- the main task is never disturbed -----------------------------------------------------------


@SETTINGS
@given(p=problems(), method=st.sampled_from(NULL_METHODS), ff=st.booleans())
def test_main_task_untouched(p: Problem, method: str, ff: bool) -> None:
    de1_dt = np.linspace(-1.0, 1.0, p.e1.size) if ff else None
    r = p.run(method, de1_dt=de1_dt)
    want = -p.lam * p.e1 - (de1_dt if ff else 0.0)
    assert r.qdot.shape == p.q.shape and np.isfinite(r.qdot).all()
    np.testing.assert_allclose(p.J1 @ r.qdot, want, atol=tol(p.J1 @ r.qdot, want, r.qdot))


# -- the iterative family against the independent reference -------------------------------------


@SETTINGS
@given(p=problems(), method=st.sampled_from(ITERATIVE), ff=st.booleans(), sec=st.booleans())
def test_iterative_matches_reference(p: Problem, method: str, ff: bool, sec: bool) -> None:
    n = p.q.size
    de1_dt = np.cos(np.arange(p.e1.size)) if ff else None
    secondary = np.sin(np.arange(n) + 1.0) if sec else None
    smooth = method.startswith("iterative-smooth")
    alpha = 2.0 if method == "iterative-smooth-e2" else 0.0
    ref = reference_iterative(
        p,
        smooth=smooth,
        alpha=alpha,
        max_levels=1 if method == "iterative-basic" else 100,
        de1_dt=de1_dt,
        secondary=secondary,
    )
    r = p.run(method, de1_dt=de1_dt, secondary=secondary)
    d = r.diagnostics
    assume(ref.consistent)  # below: every constraint can be met exactly
    assert d.critical == ref.levels
    assert d.iterations == len(ref.levels)
    assert not d.overconstrained
    np.testing.assert_allclose(d.gamma, ref.gamma, atol=1e-9)
    np.testing.assert_allclose(r.qdot, ref.qdot, atol=1e-7 * (1.0 + np.abs(ref.qdot).max()))


@SETTINGS
@given(p=problems(), method=st.sampled_from(("iterative-basic", "iterative")))
def test_stopped_axes_have_zero_velocity(p: Problem, method: str) -> None:
    r = p.run(method)
    d = r.diagnostics
    n_a = p.q.size - p.J1.shape[0]
    axes = list(d.constrained_axes)
    E = null_space(p.J1)
    well_posed = len(axes) <= n_a and (
        not axes or np.linalg.svd(E[axes], compute_uv=False).min() > 1e-3
    )
    if well_posed:
        assert not d.overconstrained
        level1 = list(d.critical[0]) if d.critical else []
        np.testing.assert_allclose(r.qdot[level1], 0.0, atol=tol(r.qdot))
        if method == "iterative":  # every level keeps every constrained axis stopped
            np.testing.assert_allclose(r.qdot[axes], 0.0, atol=tol(r.qdot))
        np.testing.assert_array_equal(d.gamma[axes], 1.0)
    elif len(axes) > n_a:
        assert d.overconstrained


@SETTINGS
@given(p=problems())
def test_smooth_slows_constrained_axes_by_gamma(p: Problem) -> None:
    """Level 1: q̇_k = -λ (1 - γ_k)(J1⁺e1)_k; level j: q̇_k = (1 - γ_k) q̇_k of level j-1."""
    r = p.run("iterative-smooth")
    d = r.diagnostics
    n_a = p.q.size - p.J1.shape[0]
    axes = list(d.constrained_axes)
    E = null_space(p.J1)
    assume(len(axes) <= n_a)
    assume(not axes or np.linalg.svd(E[axes], compute_uv=False).min() > 1e-3)
    u = np.linalg.pinv(p.J1) @ p.e1
    q_hat = p.q - p.lam * p.dt * u  # eq. 8
    if not d.critical:
        assert not p.limits.critical(p.q, q_hat).any()
        return
    K1 = list(d.critical[0])
    assert K1 == np.flatnonzero(p.limits.critical(p.q, q_hat)).tolist()
    g1 = p.limits.gamma(q_hat)[K1]
    np.testing.assert_allclose(d.gamma[K1], g1, atol=1e-12)
    np.testing.assert_allclose(r.qdot[K1], -p.lam * (1 - g1) * u[K1], atol=tol(r.qdot, u))
    for j, Kj in enumerate(d.critical[1:], start=1):
        prev = p.run("iterative-smooth", options={"max_levels": j}).qdot
        g = p.limits.gamma(p.q + p.dt * prev)[list(Kj)]
        np.testing.assert_allclose(r.qdot[list(Kj)], (1 - g) * prev[list(Kj)], atol=tol(prev))


@SETTINGS
@given(p=problems())
def test_later_levels_use_the_previous_level_prediction(p: Problem) -> None:
    """K_j = axes newly critical when predicting with the level j-1 command (eqs. 12-15)."""
    r = p.run("iterative")
    levels = r.diagnostics.critical
    for j in range(1, len(levels)):
        prev = p.run("iterative", options={"max_levels": j})
        assert prev.diagnostics.critical == levels[:j]
        crit = np.flatnonzero(p.limits.critical(p.q, p.q + p.dt * prev.qdot))
        done = {k for level in levels[:j] for k in level}
        assert list(levels[j]) == [int(k) for k in crit if k not in done]


@SETTINGS
@given(p=problems())
def test_iterative_with_one_level_is_basic(p: Problem) -> None:
    a = p.run("iterative", options={"max_levels": 1})
    b = p.run("iterative-basic")
    np.testing.assert_array_equal(a.qdot, b.qdot)
    assert a.diagnostics.critical == b.diagnostics.critical


# -- gpm and gpm-auto ------------------------------------------------------------------------------


@SETTINGS
@given(p=problems(), alpha=st.floats(0.0, 50.0))
def test_gpm_formula(p: Problem, alpha: float) -> None:
    Jp = np.linalg.pinv(p.J1)
    P = np.eye(p.q.size) - Jp @ p.J1
    want = -p.lam * (Jp @ p.e1 + alpha * P @ p.limits.gradient(p.q))  # eq. 1-2
    r = p.run("gpm", options={"alpha": alpha})
    np.testing.assert_allclose(r.qdot, want, atol=tol(want))
    assert r.diagnostics.alpha == alpha


@SETTINGS
@given(p=problems())
def test_gpm_with_zero_alpha_is_classical(p: Problem) -> None:
    a = p.run("gpm", options={"alpha": 0.0}).qdot
    b = p.run("classical").qdot
    np.testing.assert_allclose(a, b, atol=tol(b))


@SETTINGS
@given(p=problems(), sec=st.booleans())
def test_gpm_auto_stops_the_most_critical_axis(p: Problem, sec: bool) -> None:
    n = p.q.size
    secondary = np.cos(np.arange(n)) if sec else None
    r = p.run("gpm-auto", secondary=secondary)
    d = r.diagnostics
    Jp = np.linalg.pinv(p.J1)
    P = np.eye(n) - Jp @ p.J1
    x0 = -p.lam * Jp @ p.e1 + (P @ secondary if sec else 0.0)
    q_hat = p.q + p.dt * x0
    crit = np.flatnonzero(p.limits.critical(p.q, q_hat))
    g = P @ p.limits.gradient(p.q)
    assert d.alpha is not None and d.alpha >= 0.0
    if d.alpha > 0.0:
        (k,) = d.critical[0]
        assert k in crit
        margins = p.limits.margin(q_hat)[crit]
        assert p.limits.margin(q_hat)[k] == margins.min()
        np.testing.assert_allclose(d.alpha, x0[k] / (p.lam * g[k]), rtol=1e-9)
        assert abs(r.qdot[k]) <= tol(r.qdot, x0)  # eq. 9 stops axis k
    else:
        assert d.critical == ()
        np.testing.assert_allclose(r.qdot, x0, atol=tol(x0))
    if crit.size == 0:
        assert d.alpha == 0.0


@SETTINGS
@given(p=problems())
def test_gpm_auto_current_rule_takes_the_candidates_from_q(p: Problem) -> None:
    # CM01 §II-C as printed: q_k (not q̂_k) between its threshold and its limit, moving toward it;
    # among those, k is the one whose q̂_k is closest to its limit (docs/formulas.md §6.2).
    n = p.q.size
    r = p.run("gpm-auto", options={"critical_rule": "current"})
    d = r.diagnostics
    Jp = np.linalg.pinv(p.J1)
    P = np.eye(n) - Jp @ p.J1
    w = Jp @ p.e1
    q_hat = p.q - p.lam * p.dt * w
    toward = (q_hat - p.q) * (q_hat - p.limits.center) > 0
    crit = np.flatnonzero(p.limits.in_band(p.q) & toward)
    g = P @ p.limits.gradient(p.q)
    assert d.alpha is not None and d.alpha >= 0.0
    if d.alpha > 0.0:
        (k,) = d.critical[0]
        assert k in crit
        assert p.limits.margin(q_hat)[k] == p.limits.margin(q_hat)[crit].min()
        np.testing.assert_allclose(d.alpha, -w[k] / g[k], rtol=1e-9)
        assert abs(r.qdot[k]) <= tol(r.qdot, w)
    else:
        np.testing.assert_allclose(r.qdot, -p.lam * w, atol=tol(w))
    if crit.size == 0:
        assert d.alpha == 0.0 and d.critical == ()


def test_gpm_auto_rules_differ_before_an_axis_enters_its_band() -> None:
    # Axis 0 just outside its upper band, moving up: q̂_0 is in the band, q_0 is not.
    lim = JointLimits(-np.ones(3), np.ones(3), rho=0.1)
    J1 = np.array([[1.0, 0.5, 0.2]])
    q = np.array([0.79, 0.0, 0.805])  # axis 2 just inside its band
    lam, dt = 1.0, 0.1
    e1 = np.array([-0.3])  # q̇ = -λ J1⁺ e1 moves axis 0 up by 0.02 in one step
    pred = paper_law("gpm-auto")(J1=J1, e1=e1, q=q, limits=lim, lam=lam, dt=dt)
    cur = paper_law("gpm-auto", critical_rule="current")(
        J1=J1, e1=e1, q=q, limits=lim, lam=lam, dt=dt
    )
    assert pred.diagnostics.critical == ()  # axis 0 chosen (q̂ closest) but e2_0 = 0: α = 0
    assert cur.diagnostics.critical == ((2,),)  # only axis 2 is in its band now
    assert abs(cur.qdot[2]) < 1e-12


def test_gpm_auto_alpha_max_caps_the_gain() -> None:
    p = _single_band_axis(k=1, alpha_sign=1)
    free = p.run("gpm-auto").diagnostics.alpha
    assert free is not None and free > 0.0
    capped = p.run("gpm-auto", options={"alpha_max": free / 2})
    assert capped.diagnostics.alpha == pytest.approx(free / 2)
    assert any("capped" in note for note in capped.diagnostics.notes)


# -- no critical axis, invariance, e2 ---------------------------------------------------------------


@SETTINGS
@given(p=problems(), method=st.sampled_from((*ITERATIVE, "gpm-auto")))
def test_no_critical_axis_is_classical(p: Problem, method: str) -> None:
    p = p._replace(q=p.limits.center.copy(), dt=1e-4)  # far from every band, tiny step
    r = p.run(method)
    assert r.diagnostics.critical == ()
    np.testing.assert_allclose(r.qdot, p.run("classical").qdot, atol=tol(r.qdot))


@SETTINGS
@given(p=problems(), method=st.sampled_from(NULL_METHODS), seed=st.integers(0, 2**32 - 1))
def test_basis_independence(p: Problem, method: str, seed: int) -> None:
    """Rotating J1's rows (and e1) keeps J1⁺e1 and Ker J1, so the command must not change."""
    m = p.J1.shape[0]
    Q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(m, m)))
    a = p.run(method)
    b = p._replace(J1=Q @ p.J1, e1=Q @ p.e1).run(method)
    assert a.diagnostics.critical == b.diagnostics.critical
    np.testing.assert_allclose(b.qdot, a.qdot, atol=1e-7 * (1 + np.abs(a.qdot).max()))


def _single_band_axis(*, k: int, alpha_sign: int, n: int = 6, m: int = 2) -> Problem:
    """One axis k in its upper band moving up, the others at mid-range (no other critical axis)."""
    rng = np.random.default_rng(7)
    J1 = rng.normal(size=(m, n))
    lim = JointLimits(-np.ones(n), np.ones(n), rho=0.1)
    q = np.zeros(n)
    q[k] = 0.85
    e1 = rng.normal(size=m)
    u = np.linalg.pinv(J1) @ e1
    if alpha_sign * u[k] > 0:  # moving up needs q̇_k = -λ u_k > 0
        e1 = -e1
    return Problem(J1, e1, q, lim, 0.5, 0.01)


@pytest.mark.parametrize("k", range(6))
def test_e2_moves_the_critical_axis_away(k: int) -> None:
    p = _single_band_axis(k=k, alpha_sign=1)
    s = p.run("iterative-smooth")
    e = p.run("iterative-smooth-e2", options={"alpha": 2.0})
    assert s.diagnostics.critical == e.diagnostics.critical == ((k,),)
    P = np.eye(6) - np.linalg.pinv(p.J1) @ p.J1
    e2 = p.limits.gradient(p.q)
    assert e2[k] > 0
    assert s.qdot[k] >= 0.0  # slowed, not reversed
    assert e.qdot[k] < s.qdot[k]  # pushed back toward the middle (away from q̄_max)
    np.testing.assert_allclose(e.qdot[k] - s.qdot[k], -p.lam * 2.0 * P[k, k] * e2[k], atol=1e-12)


@SETTINGS
@given(p=problems(), alpha=st.floats(0.1, 10.0))
def test_e2_level_one_system_unchanged(p: Problem, alpha: float) -> None:
    """Eq. 16 is kept: on level-1 axes q̇ differs from iterative-smooth by exactly -λ α (J1^⊥ e2)."""
    s = p.run("iterative-smooth", options={"max_levels": 1})
    e = p.run("iterative-smooth-e2", options={"alpha": alpha, "max_levels": 1})
    assert s.diagnostics.critical == e.diagnostics.critical
    P = np.eye(p.q.size) - np.linalg.pinv(p.J1) @ p.J1
    shift = -p.lam * alpha * P @ p.limits.gradient(p.q)
    np.testing.assert_allclose(e.qdot, s.qdot + shift, atol=tol(s.qdot, shift))


@SETTINGS
@given(p=problems(), method=st.sampled_from(("iterative-basic", "iterative")))
def test_secondary_does_not_restart_stopped_axes(p: Problem, method: str) -> None:
    n = p.q.size
    secondary = 3.0 * np.sin(np.arange(n) + 0.5)
    r = p.run(method, secondary=secondary)
    d = r.diagnostics
    np.testing.assert_allclose(p.J1 @ r.qdot, -p.lam * p.e1, atol=tol(r.qdot, p.e1))
    axes = list(d.constrained_axes)
    n_a = n - p.J1.shape[0]
    E = null_space(p.J1)
    if axes and len(axes) <= n_a and np.linalg.svd(E[axes], compute_uv=False).min() > 1e-3:
        level1 = list(d.critical[0])
        np.testing.assert_allclose(r.qdot[level1], 0.0, atol=tol(r.qdot, secondary))


# -- diagnostics -------------------------------------------------------------------------------------


@SETTINGS
@given(p=problems(), method=st.sampled_from(ITERATIVE))
def test_iterative_diagnostics_shapes(p: Problem, method: str) -> None:
    d = p.run(method).diagnostics
    n, m = p.q.size, p.J1.shape[0]
    assert d.method == method
    assert d.task_rank == m and not d.rank_deficient
    assert d.projector_rank == n - m
    assert d.a is not None and d.a.shape == (n - m,)
    assert d.b is not None and d.b.shape == ((n - m) * max(d.iterations - 1, 0),)
    assert d.gamma is not None and d.gamma.shape == (n,)
    assert d.iterations == len(d.critical)
    constrained = np.zeros(n, dtype=bool)
    constrained[list(d.constrained_axes)] = True
    assert (d.gamma[~constrained] == 0).all() and (d.gamma >= 0).all() and (d.gamma <= 1).all()
    assert sum(map(len, d.critical)) == len(d.constrained_axes)  # no axis twice
    assert (d.alpha is not None) == (method == "iterative-smooth-e2")


# -- degenerate inputs -------------------------------------------------------------------------------


def _run_all(p: Problem, **kw: object) -> dict[str, LawResult]:
    out = {}
    for method in NULL_METHODS:
        r = p.run(method, **kw)
        assert r.qdot.shape == p.q.shape and np.isfinite(r.qdot).all(), method
        assert r.diagnostics.method == method
        out[method] = r
    return out


def test_more_critical_axes_than_redundancy_is_flagged() -> None:
    J1 = np.array([[1.0, 1.0, 1.0, 1.0], [1.0, -1.0, 1.0, -1.0]])
    e1 = np.array([-1.0, 0.0])  # J1⁺e1 = -(1, 1, 1, 1)/4: every axis moves up
    lim = JointLimits(-np.ones(4), np.ones(4))
    p = Problem(J1, e1, np.full(4, 0.95), lim, 1.0, 0.04)
    out = _run_all(p)
    for method in ITERATIVE:
        d = out[method].diagnostics
        assert d.overconstrained, method
        assert d.constrained_axes == (0, 1, 2, 3)
        assert any("least-squares" in note for note in d.notes)
        np.testing.assert_allclose(J1 @ out[method].qdot, -e1, atol=1e-12)


def test_rank_deficient_task() -> None:
    rng = np.random.default_rng(3)
    row = rng.normal(size=6)
    J1 = np.vstack([row, 2.0 * row, rng.normal(size=6)])  # rank 2 < m = 3
    e1 = rng.normal(size=3)
    lim = JointLimits(-np.ones(6), np.ones(6))
    q = np.array([0.95, -0.95, 0.0, 0.85, -0.9, 0.5])
    p = Problem(J1, e1, q, lim, 0.7, 0.05)
    Jp = np.linalg.pinv(J1)
    for method, r in _run_all(p).items():
        d = r.diagnostics
        assert d.task_rank == 2 and d.rank_deficient, method
        assert d.projector_rank == 4
        # the reachable part of the task is still exact: J1 q̇ = -λ J1 J1⁺ e1
        np.testing.assert_allclose(J1 @ r.qdot, -p.lam * J1 @ Jp @ e1, atol=1e-9)
        if method in ITERATIVE:
            assert d.a is not None and d.a.shape == (4,)


@pytest.mark.parametrize("m", [6, 7])
def test_no_redundancy_reduces_to_classical(m: int) -> None:
    rng = np.random.default_rng(m)
    J1 = rng.normal(size=(m, 6))
    e1 = rng.normal(size=m)
    lim = JointLimits(-np.ones(6), np.ones(6))
    q = np.array([0.95, -0.95, 0.0, 0.9, -0.8, 1.0])
    p = Problem(J1, e1, q, lim, 0.5, 0.05)
    classical = p.run("classical").qdot
    for method, r in _run_all(p, secondary=np.ones(6)).items():
        d = r.diagnostics
        np.testing.assert_allclose(r.qdot, classical, atol=1e-12, err_msg=method)
        assert d.projector_rank == 0
        assert any("no redundancy" in note for note in d.notes), method
        if method in ITERATIVE:
            assert d.a is not None and d.a.shape == (0,)
            assert d.overconstrained == bool(d.critical)


@pytest.mark.parametrize("q0", [0.8, 1.0, -0.8, -1.0])  # thresholds at ±0.8, limits at ±1
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_exactly_at_threshold_and_at_limit(q0: float, sign: float) -> None:
    J1 = np.array([[1.0, 1.0, 1.0, 0.0, 0.3, 0.1], [0.0, 1.0, -1.0, 1.0, 0.2, 0.4]])
    lim = JointLimits(-np.ones(6), np.ones(6), rho=0.1)
    q = np.array([q0, 0.0, 0.0, 0.0, 0.0, 0.0])
    p = Problem(J1, sign * np.array([1.0, 0.5]), q, lim, 1.0, 0.05)
    out = _run_all(p)
    v0 = p.run("classical").qdot[0]
    toward = v0 * q0 > 0  # axis 0 driven toward the limit (or threshold) it sits on
    for method in ITERATIVE:
        r = out[method]
        assert r.diagnostics.critical == (((0,),) if toward else ()), method
    if toward:
        at_limit = abs(q0) == 1.0
        # stopped by the non-smooth schemes; by the smooth ones only at the real limit (γ = 1)
        assert out["iterative-basic"].qdot[0] == pytest.approx(0.0, abs=1e-12)
        assert out["iterative"].qdot[0] == pytest.approx(0.0, abs=1e-12)
        g = out["iterative-smooth"].diagnostics.gamma
        assert g is not None and (g[0] == 1.0) == at_limit and 0.0 < g[0] <= 1.0
        assert out["iterative-smooth"].qdot[0] == pytest.approx((1 - g[0]) * v0, abs=1e-12)
        assert out["gpm-auto"].diagnostics.critical in (((0,),), ())


def test_zero_error() -> None:
    lim = JointLimits(-np.ones(5), np.ones(5))
    q = np.array([0.95, -0.9, 0.0, 1.0, -1.0])
    J1 = np.random.default_rng(0).normal(size=(2, 5))
    p = Problem(J1, np.zeros(2), q, lim, 0.5, 0.05)
    out = _run_all(p)
    for method in ("gpm-auto", *ITERATIVE[:3]):
        np.testing.assert_array_equal(out[method].qdot, 0.0)
        assert out[method].diagnostics.critical == ()
    # e2 still pushes the axes in their band back toward the middle
    P = np.eye(5) - np.linalg.pinv(J1) @ J1
    e2 = lim.gradient(q)
    for method in ("gpm", "iterative-smooth-e2"):
        np.testing.assert_allclose(out[method].qdot, -0.5 * 2.0 * P @ e2, atol=1e-12)
        assert e2 @ out[method].qdot <= 0.0


def test_zero_jacobian() -> None:
    lim = JointLimits(-np.ones(4), np.ones(4))
    p = Problem(np.zeros((2, 4)), np.ones(2), np.array([0.95, 0.0, 0.0, -1.0]), lim, 0.5, 0.05)
    for method, r in _run_all(p).items():
        assert r.diagnostics.task_rank == 0 and r.diagnostics.rank_deficient, method
        assert r.diagnostics.projector_rank == 4


# -- options -----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("method", "options"),
    [
        ("gpm", {"alpha": -1.0}),
        ("gpm", {"alpha": float("nan")}),
        ("gpm", {"alpha": float("inf")}),
        ("gpm-auto", {"alpha_max": 0.0}),
        ("gpm-auto", {"alpha_max": -2.0}),
        ("gpm-auto", {"alpha_max": float("nan")}),
        ("gpm-auto", {"critical_rule": "next"}),
        ("iterative", {"max_levels": 0}),
        ("iterative", {"max_levels": 1.5}),
        ("iterative", {"max_levels": True}),
        ("iterative-smooth", {"max_levels": -1}),
        ("iterative-smooth-e2", {"alpha": -0.1}),
        ("iterative-basic", {"max_levels": 2}),  # the basic scheme has one level by definition
        ("iterative", {"alpha": 1.0}),  # only the e2 variant has a gradient term
        ("iterative-smooth", {"smooth": False}),
    ],
)
def test_invalid_options(method: str, options: dict[str, object]) -> None:
    with pytest.raises(ConfigurationError):
        make_law(method, **options)


def test_valid_options_and_repr() -> None:
    assert paper_law("gpm-auto", alpha_max=float("inf")).alpha_max == float("inf")  # type: ignore[attr-defined]
    law = paper_law("iterative-smooth-e2", alpha=0.5, max_levels=3)
    assert "alpha=0.5" in repr(law) and "max_levels=3" in repr(law)
    assert "max_levels" not in repr(paper_law("iterative-basic"))
    assert paper_law("iterative", max_levels=np.int64(2)).max_levels == 2  # type: ignore[attr-defined]


def test_ill_conditioned_constraint_is_reported_and_can_be_capped() -> None:
    """Stopping an axis the null space barely moves needs a huge motion (campaign finding).

    J1 = [1, 0, 1e-5]: Ker J1 moves axis 0 only through the direction (-1e-5, 0, 1), so the
    constraint row of axis 0 has singular value ~1e-5.
    """
    limits = JointLimits(-np.ones(3), np.ones(3))
    kw = dict(
        J1=np.array([[1.0, 0.0, 1e-5]]),
        e1=np.array([-1.0]),
        q=np.array([0.85, 0.0, 0.0]),
        limits=limits,
        lam=0.5,
        dt=0.04,
    )
    exact = paper_law("iterative")(**kw)
    assert exact.diagnostics.critical[0] == (0,)  # (the huge motion then drives axis 2 in)
    assert abs(exact.qdot[0]) < 1e-9  # CM01: stopped, whatever it costs ...
    assert np.abs(exact.qdot).max() > 1e3  # ... here a huge motion of axis 2
    assert any("ill-conditioned constraints" in n for n in exact.diagnostics.notes)
    capped = paper_law("iterative", constraint_rcond=1e-2)(**kw)
    assert np.abs(capped.qdot).max() < 1.0  # no amplification
    assert capped.diagnostics.overconstrained  # the constraint is reported as not met
    np.testing.assert_allclose(kw["J1"] @ capped.qdot, -0.5 * kw["e1"], atol=1e-12)
    with pytest.raises(ConfigurationError, match="constraint_rcond"):
        make_law("iterative-smooth", constraint_rcond=1.5)
