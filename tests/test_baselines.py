"""Tests of the modern baselines: wln, sns, qp and large-projection (docs/formulas.md §10).

Expected values are computed independently in the tests (numpy's pinv, the printed
closed forms, finite differences, a linear program), never copied from the laws.
"""

from __future__ import annotations

import itertools
import math
import pickle
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

import redservo
from redservo import ConfigurationError, InfeasibleError, JointLimits, make_law
from redservo.redundancy import qp as qp_module
from redservo.redundancy.large_projection import norm_projector, switched_projector
from redservo.redundancy.qp import qp_velocity_bounds
from redservo.redundancy.sns import _task_scaling
from redservo.redundancy.wln import joint_limit_index, joint_limit_index_gradient
from tests.laws import paper_law

SETTINGS = settings(max_examples=60, deadline=None)
seeds = st.integers(0, 2**32 - 1)
BASELINES = ("wln", "sns", "qp", "large-projection")


# -- problem generators ---------------------------------------------------------------------------


@dataclass
class Problem:
    J1: np.ndarray
    e1: np.ndarray
    q: np.ndarray
    limits: JointLimits
    lam: float
    dt: float

    def kwargs(self) -> dict[str, object]:
        return {
            "J1": self.J1,
            "e1": self.e1,
            "q": self.q,
            "limits": self.limits,
            "lam": self.lam,
            "dt": self.dt,
        }


def random_limits(rng: np.random.Generator, n: int) -> JointLimits:
    lo = rng.uniform(-3.0, 0.0, n)
    return JointLimits(lo, lo + rng.uniform(0.2, 4.0, n))


def random_q(
    rng: np.random.Generator, limits: JointLimits, *, at_limits: bool = True
) -> np.ndarray:
    """Joint positions inside the limits: interior, near a limit (1e-6..5 % of the range) or at one."""
    n = limits.n
    kinds = ["interior", "near"] + (["at"] if at_limits else [])
    frac = np.empty(n)
    for i in range(n):
        kind = kinds[int(rng.integers(len(kinds)))]
        if kind == "interior":
            f = rng.uniform(0.05, 0.95)
        elif kind == "near":
            f = 10.0 ** rng.uniform(-6.0, math.log10(0.05))
        else:
            f = 0.0
        frac[i] = f if rng.random() < 0.5 else 1.0 - f
    return np.clip(limits.q_min + frac * limits.range, limits.q_min, limits.q_max)


@st.composite
def problems(
    draw: st.DrawFn, *, square: bool = False, at_limits: bool = True, e_scale: float = 1.0
) -> Problem:
    """Random full-row-rank J1 (m < n unless ``square``), random e1, q inside the limits."""
    rng = np.random.default_rng(draw(seeds))
    n = draw(st.integers(2, 7))
    m = n if square else draw(st.integers(1, n - 1))
    J1 = rng.normal(size=(m, n))
    e1 = rng.normal(size=m) * e_scale * 10.0 ** rng.uniform(-2.0, 1.0)
    limits = random_limits(rng, n)
    q = random_q(rng, limits, at_limits=at_limits)
    lam = draw(st.floats(0.05, 3.0))
    dt = draw(st.sampled_from([0.001, 0.01, 0.04, 0.2]))
    return Problem(J1, e1, q, limits, lam, dt)


def classical_qdot(J1: np.ndarray, e1: np.ndarray, lam: float) -> np.ndarray:
    return np.asarray(-lam * np.linalg.pinv(J1) @ e1)


def position_velocity_bounds(p: Problem) -> tuple[np.ndarray, np.ndarray]:
    return (p.limits.q_min - p.q) / p.dt, (p.limits.q_max - p.q) / p.dt


def assert_stays_within_limits(p: Problem, qdot: np.ndarray) -> None:
    q_next = p.q + qdot * p.dt
    assert np.all(q_next >= p.limits.q_min - 1e-9), q_next - p.limits.q_min
    assert np.all(q_next <= p.limits.q_max + 1e-9), p.limits.q_max - q_next


# -- registry -------------------------------------------------------------------------------------


def test_baselines_are_registered() -> None:
    for name in BASELINES:
        assert name in redservo.METHODS
        assert paper_law(name).name == name


# -- wln ------------------------------------------------------------------------------------------


@SETTINGS
@given(seed=seeds)
def test_wln_index_gradient_matches_finite_differences(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 7))
    limits = random_limits(rng, n)
    q = limits.q_min + rng.uniform(0.02, 0.98, n) * limits.range
    grad = joint_limit_index_gradient(q, limits)
    h = 1e-6 * limits.range
    fd = np.array(
        [
            (
                joint_limit_index(q + h[i] * np.eye(n)[i], limits)
                - joint_limit_index(q - h[i] * np.eye(n)[i], limits)
            )
            / (2.0 * h[i])
            for i in range(n)
        ]
    )
    assert np.allclose(grad, fd, rtol=1e-5, atol=1e-6)


def test_wln_index_is_one_per_joint_at_mid_range_and_infinite_at_a_limit() -> None:
    limits = JointLimits([-1.0, 0.0, 2.0], [1.0, 3.0, 2.5])
    assert joint_limit_index(limits.center, limits) == pytest.approx(3.0)
    assert np.all(joint_limit_index_gradient(limits.center, limits) == 0.0)
    q = limits.center.copy()
    q[1] = limits.q_max[1]
    assert joint_limit_index(q, limits) == math.inf
    g = joint_limit_index_gradient(q, limits)
    assert g[1] == math.inf and not np.isnan(g).any()


@SETTINGS
@given(p=problems(at_limits=False))
def test_wln_equals_pinv_when_no_joint_moves_toward_a_limit(p: Problem) -> None:
    qdot0 = classical_qdot(p.J1, p.e1, p.lam)
    # put every joint on the side of mid-range that its motion leaves
    q = p.q.copy()
    side = np.abs(p.q - p.limits.center)
    q = p.limits.center - np.sign(qdot0) * side
    p.q = q
    res = paper_law("wln")(**p.kwargs())
    assert np.allclose(res.qdot, qdot0, rtol=1e-9, atol=1e-12)
    assert res.diagnostics.critical == ()


def wln_closed_form(p: Problem) -> np.ndarray:
    """The printed formula, with H' written out independently and an explicit W."""
    lo, hi, q = p.limits.q_min, p.limits.q_max, p.q
    dH = (hi - lo) ** 2 * (2 * q - hi - lo) / (4 * (hi - q) ** 2 * (q - lo) ** 2)
    xdot = -p.lam * p.e1
    toward = dH * (np.linalg.pinv(p.J1) @ xdot) > 0
    W_inv = np.diag(np.where(toward, 1.0 / (1.0 + np.abs(dH)), 1.0))
    return np.asarray(W_inv @ p.J1.T @ np.linalg.solve(p.J1 @ W_inv @ p.J1.T, xdot))


@SETTINGS
@given(p=problems(at_limits=False))
def test_wln_matches_the_printed_formula(p: Problem) -> None:
    # keep q at least 1 % of the range from the limits so the explicit solve is well conditioned
    frac = np.clip((p.q - p.limits.q_min) / p.limits.range, 0.01, 0.99)
    p.q = p.limits.q_min + frac * p.limits.range
    res = paper_law("wln")(**p.kwargs())
    expected = wln_closed_form(p)
    assert np.allclose(res.qdot, expected, rtol=1e-7, atol=1e-9 * (1 + np.abs(expected).max()))


@SETTINGS
@given(p=problems())
def test_wln_executes_the_task_for_full_row_rank(p: Problem) -> None:
    res = paper_law("wln")(**p.kwargs())
    xdot = -p.lam * p.e1
    if any("blocked" in s for s in res.diagnostics.notes):
        return  # joints at a limit removed task directions (tested separately)
    assert np.allclose(p.J1 @ res.qdot, xdot, rtol=1e-6, atol=1e-6 * (1 + np.abs(xdot).max()))


@SETTINGS
@given(seed=seeds, k=st.integers(0, 6))
def test_wln_damps_a_joint_moving_toward_a_nearby_limit(seed: int, k: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 8))
    k = k % n
    m = int(rng.integers(1, n))
    J1 = rng.normal(size=(m, n))
    e1 = rng.normal(size=m)
    limits = random_limits(rng, n)
    qdot0 = classical_qdot(J1, e1, 1.0)
    if abs(qdot0[k]) < 1e-6:
        return
    speeds = []
    for d in (0.3, 0.1, 0.01, 1e-3, 0.0):  # distance to the limit k moves toward, fraction of range
        q = limits.center.copy()
        q[k] = (
            limits.q_max[k] - d * limits.range[k]
            if qdot0[k] > 0
            else limits.q_min[k] + d * limits.range[k]
        )
        res = paper_law("wln")(J1=J1, e1=e1, q=q, limits=limits, lam=1.0, dt=0.04)
        speeds.append(abs(res.qdot[k]))
        assert res.diagnostics.critical == ((k,),)
        # the task is kept: removing column k leaves J1 full row rank (m <= n - 1)
        assert np.allclose(J1 @ res.qdot, -e1, atol=1e-7)
    assert speeds[0] < abs(qdot0[k])
    assert all(a > b for a, b in itertools.pairwise(speeds))
    assert speeds[-1] == 0.0  # at the limit the joint is blocked


def test_wln_square_jacobian_reduces_to_the_inverse() -> None:
    rng = np.random.default_rng(7)
    J1 = rng.normal(size=(5, 5))
    e1 = rng.normal(size=5)
    limits = random_limits(rng, 5)
    q = limits.q_min + np.array([0.02, 0.5, 0.97, 0.1, 0.6]) * limits.range
    res = paper_law("wln")(J1=J1, e1=e1, q=q, limits=limits, lam=0.5, dt=0.04)
    assert np.allclose(res.qdot, np.linalg.solve(J1, -0.5 * e1), rtol=1e-8)


def test_wln_history_mode_is_stateful_and_uses_the_change_of_the_gradient() -> None:
    rng = np.random.default_rng(3)
    J1 = rng.normal(size=(2, 4))
    e1 = rng.normal(size=2)
    limits = JointLimits(-np.ones(4), np.ones(4))
    law = paper_law("wln", mode="history")
    assert law.stateful and not paper_law("wln").stateful
    q_a = np.array([0.8, 0.0, 0.0, 0.0])
    q_b = np.array([0.9, 0.0, 0.0, 0.0])  # joint 0 got closer to its upper limit
    kw = {"J1": J1, "e1": e1, "limits": limits, "lam": 1.0, "dt": 0.04}
    first = law(q=q_a, **kw)
    assert np.array_equal(first.qdot, paper_law("wln")(q=q_a, **kw).qdot)  # no history yet
    toward = law(q=q_b, **kw)
    assert 0 in toward.diagnostics.constrained_axes
    away = law(q=q_a, **kw)  # |∂H/∂q_0| decreased
    assert 0 not in away.diagnostics.constrained_axes
    law.reset()
    again = law(q=q_b, **kw)
    assert np.array_equal(again.qdot, paper_law("wln")(q=q_b, **kw).qdot)


def test_wln_bad_mode_and_copies() -> None:
    with pytest.raises(ConfigurationError, match="mode"):
        make_law("wln", mode="previous")
    for mode in ("pinv", "history"):
        law = paper_law("wln", mode=mode)
        clone = pickle.loads(pickle.dumps(law))
        assert type(clone) is type(law) and clone.stateful == law.stateful
        assert repr(clone) == repr(law)


# -- sns ------------------------------------------------------------------------------------------


@st.composite
def sns_options(draw: st.DrawFn, n: int) -> dict[str, object]:
    opts: dict[str, object] = {}
    kind = draw(st.sampled_from(["none", "scalar", "array"]))
    if kind == "scalar":
        opts["v_max"] = draw(st.floats(0.05, 5.0))
    elif kind == "array":
        opts["v_max"] = np.array(draw(st.lists(st.floats(0.05, 5.0), min_size=n, max_size=n)))
    if draw(st.booleans()):
        opts["a_max"] = draw(st.floats(0.5, 20.0))
    if draw(st.booleans()):
        opts["margin"] = draw(st.floats(0.5, 1.0))
    return opts


@SETTINGS
@given(data=st.data(), p=problems(e_scale=30.0))
def test_sns_respects_the_velocity_bounds(data: st.DataObject, p: Problem) -> None:
    opts = data.draw(sns_options(p.J1.shape[1]))
    secondary = data.draw(st.none() | st.just(np.random.default_rng(0).normal(size=p.J1.shape[1])))
    res = paper_law("sns", **opts)(**p.kwargs(), secondary=secondary)
    assert_stays_within_limits(p, res.qdot)
    v_max = opts.get("v_max")
    if v_max is not None:
        assert np.all(np.abs(res.qdot) <= np.asarray(v_max) + 1e-12)
    a_max = opts.get("a_max")
    if a_max is not None:  # braking bound: the joint can still stop before its limit
        d = np.where(res.qdot > 0, p.limits.q_max - p.q, p.q - p.limits.q_min)
        assert np.all(res.qdot**2 <= 2 * float(a_max) * np.maximum(d, 0) + 1e-12)
    s = res.diagnostics.scale
    assert s is not None and 0.0 <= s <= 1.0
    assert not any("clip" in note for note in res.diagnostics.notes)


@SETTINGS
@given(p=problems(e_scale=30.0))
def test_sns_keeps_the_task_direction_and_never_beats_the_lp_optimum(p: Problem) -> None:
    res = paper_law("sns")(**p.kwargs())
    s = res.diagnostics.scale
    assert s is not None
    xdot = -p.lam * p.e1
    assert np.allclose(p.J1 @ res.qdot, s * xdot, atol=1e-8 * (1 + np.abs(xdot).max()))
    if s == 1.0 and not res.diagnostics.critical:
        assert np.allclose(p.J1 @ res.qdot, xdot, atol=1e-10 * (1 + np.abs(xdot).max()))
    # the largest feasible scale: max s s.t. J1 q̇ = s ẋ, bounds, 0 <= s <= 1
    lo, hi = position_velocity_bounds(p)
    m, n = p.J1.shape
    lp = linprog(
        np.r_[np.zeros(n), -1.0],
        A_eq=np.hstack([p.J1, -xdot[:, None]]),
        b_eq=np.zeros(m),
        bounds=[*zip(lo, hi), (0.0, 1.0)],
    )
    assert lp.status == 0
    assert s <= lp.x[-1] + 1e-7


@SETTINGS
@given(p=problems(at_limits=False))
def test_sns_and_qp_return_the_classical_solution_when_it_is_feasible(p: Problem) -> None:
    frac = np.clip((p.q - p.limits.q_min) / p.limits.range, 0.1, 0.9)
    p.q = p.limits.q_min + frac * p.limits.range
    lo, hi = position_velocity_bounds(p)
    qdot0 = classical_qdot(p.J1, p.e1, p.lam)
    room = min(np.abs(lo).min(), hi.min())
    p.e1 = p.e1 * 0.5 * room / max(np.abs(qdot0).max(), 1e-300)  # now |q̇0| <= room/2
    expected = classical_qdot(p.J1, p.e1, p.lam)
    tol = 1e-12 * np.abs(expected).max()
    res_sns = paper_law("sns")(**p.kwargs())
    assert np.allclose(res_sns.qdot, expected, rtol=1e-9, atol=tol)
    assert res_sns.diagnostics.scale == 1.0 and res_sns.diagnostics.critical == ()
    for solver in ("auto", "scipy"):
        res_qp = paper_law("qp", solver=solver)(**p.kwargs())
        assert np.allclose(res_qp.qdot, expected, rtol=1e-9, atol=tol)
        assert res_qp.diagnostics.critical == ()
        assert "solver: none" in res_qp.diagnostics.notes[-1]


def test_sns_scaling_ignores_saturated_joints() -> None:
    """The masking fix of docs/formulas.md §10.4 on the scaling step itself.

    Joint 0 is saturated at its upper bound; round-off left ``a_0 = -1e-17`` and
    ``b_0`` a hair above the bound. Unmasked, it would claim that no scale in
    [0, 1] is feasible (``S_min,0 = 100``); masked, joint 1 limits the scale to 0.5.
    """
    a = np.array([-1e-17, 1.0])
    b = np.array([1.0 + 1e-15, 0.0])
    lo, hi = np.array([-1.0, -1.0]), np.array([1.0, 0.5])
    tol = np.full(2, 1e-10)
    masked = _task_scaling(a, b, lo, hi, np.array([False, True]), tol)
    assert masked == (0.5, 1)
    assert _task_scaling(a, b, lo, hi, np.array([True, True]), tol) == (0.0, 1)


def test_sns_masking_keeps_every_case_feasible() -> None:
    """docs/formulas.md §10.4: m = 3, n = 7, large errors, every case feasible and scaled along ẋ."""
    rng = np.random.default_rng(12)
    law = paper_law("sns", v_max=1.0)
    saturated = 0
    for _ in range(300):
        J1 = rng.normal(size=(3, 7))
        e1 = 3.0 * rng.normal(size=3)
        limits = JointLimits(-np.ones(7), np.ones(7))
        q = rng.uniform(-1.0, 1.0, 7)
        p = Problem(J1, e1, q, limits, 1.0, 0.1)
        res = law(**p.kwargs())
        assert_stays_within_limits(p, res.qdot)
        assert np.all(np.abs(res.qdot) <= 1.0 + 1e-12)
        # feasible by the algorithm itself, not by the final safety clip
        assert not any("clip" in s for s in res.diagnostics.notes)
        s = res.diagnostics.scale
        assert s is not None
        assert np.allclose(J1 @ res.qdot, -s * e1, atol=1e-9)
        saturated += bool(res.diagnostics.critical)
    assert saturated > 150  # the test exercises the saturation branch


def test_sns_bad_options() -> None:
    for bad in (0.0, -1.0, [1.0, 0.0], float("nan"), [[1.0]]):
        with pytest.raises(ConfigurationError, match="v_max"):
            make_law("sns", v_max=bad)
    with pytest.raises(ConfigurationError, match="a_max"):
        make_law("sns", a_max=-2.0)
    for bad_margin in (0.0, 1.5, -0.2):
        with pytest.raises(ConfigurationError, match="margin"):
            make_law("sns", margin=bad_margin)
    limits = JointLimits(-np.ones(3), np.ones(3))
    kw = {"J1": np.ones((1, 3)), "e1": [1.0], "limits": limits, "lam": 1.0, "dt": 0.1}
    with pytest.raises(ConfigurationError, match="3 joints"):
        make_law("sns", v_max=[1.0, 1.0])(q=np.zeros(3), **kw)
    # q beyond a limit (within the validation tolerance) by more than v_max dt can recover
    with pytest.raises(InfeasibleError, match="joint 0"):
        make_law("sns", v_max=1e-12)(q=[1.0 + 5e-10, 0.0, 0.0], **kw)


# -- qp -------------------------------------------------------------------------------------------


def task_cost(p: Problem, qdot: np.ndarray) -> float:
    return float(np.sum((p.J1 @ qdot + p.lam * p.e1) ** 2))


@SETTINGS
@given(p=problems(e_scale=30.0), v_max=st.none() | st.floats(0.05, 5.0))
def test_qp_respects_the_bounds_and_is_at_least_as_good_as_sns(
    p: Problem, v_max: float | None
) -> None:
    results = {s: paper_law("qp", solver=s, v_max=v_max)(**p.kwargs()) for s in ("auto", "scipy")}
    sns = paper_law("sns", v_max=v_max)(**p.kwargs())
    clipped = np.clip(classical_qdot(p.J1, p.e1, p.lam), *position_velocity_bounds(p))
    if v_max is not None:
        clipped = np.clip(clipped, -v_max, v_max)
    scale = 1.0 + task_cost(p, np.zeros_like(p.q))
    for res in results.values():
        assert_stays_within_limits(p, res.qdot)
        if v_max is not None:
            assert np.all(np.abs(res.qdot) <= v_max + 1e-12)
        # both sns's and the clipped classical command are feasible: the optimum is no worse
        assert task_cost(p, res.qdot) <= task_cost(p, sns.qdot) + 1e-7 * scale
        assert task_cost(p, res.qdot) <= task_cost(p, clipped) + 1e-7 * scale
    # two independent solvers reach the same optimal value
    a, b = (task_cost(p, results[s].qdot) for s in ("auto", "scipy"))
    assert abs(a - b) <= 1e-7 * scale


@SETTINGS
@given(
    p=problems(),
    margin=st.floats(0.0, 0.45),
    k_p=st.floats(0.05, 1.0),
    v_max=st.none() | st.floats(0.01, 5.0),
)
def test_qp_bounds_are_consistent_and_safe(
    p: Problem, margin: float, k_p: float, v_max: float | None
) -> None:
    vm = None if v_max is None else np.asarray(v_max)
    lo, hi, conflicts = qp_velocity_bounds(p.q, p.limits, p.dt, k_p=k_p, margin=margin, v_max=vm)
    assert np.all(lo <= hi)
    for bound in (lo, hi):
        assert_stays_within_limits(p, bound)
        if v_max is not None:
            assert np.all(np.abs(bound) <= v_max)
    band = margin * p.limits.range
    inside = (p.q >= p.limits.q_min + band) & (p.q <= p.limits.q_max - band)
    assert np.all(lo[inside] <= 0.0) and np.all(hi[inside] >= 0.0)
    assert np.all(lo[~inside] * hi[~inside] >= 0.0)  # outside the band: pushed back, 0 excluded
    assert not set(conflicts) & set(np.flatnonzero(inside).tolist())


def test_qp_pushes_back_from_inside_the_margin_band() -> None:
    limits = JointLimits(-np.ones(3), np.ones(3))
    J1 = np.array([[1.0, 1.0, 1.0]])
    q = np.array([-0.95, 0.0, 0.0])  # inside a 10 % band at the lower limit
    kw = {"J1": J1, "e1": [0.0], "q": q, "limits": limits, "lam": 1.0, "dt": 0.1}
    res = paper_law("qp", margin=0.1, k_p=0.5)(**kw)
    expected_lo = 0.5 * (-1.0 + 0.2 - (-0.95)) / 0.1  # k_p (q_min + margin Δq - q)/dt = 0.75
    assert res.qdot[0] >= expected_lo - 1e-9
    assert 0 in res.diagnostics.constrained_axes
    # the push-back exceeds v_max: the velocity limit wins, the joint moves up at v_max
    res = paper_law("qp", margin=0.1, k_p=0.5, v_max=0.2)(**kw)
    assert res.qdot[0] == pytest.approx(0.2)
    assert any("exceeds v_max" in s for s in res.diagnostics.notes)


def test_qp_needs_no_qp_library(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without qpsolvers the default solver is the compiled one; scipy's gives its command."""
    monkeypatch.setattr(qp_module, "qpsolvers_module", lambda: None)
    limits = JointLimits(-np.ones(3), np.ones(3))
    kw = {"J1": np.eye(2, 3), "e1": [50.0, -50.0], "q": np.zeros(3), "limits": limits}
    res = paper_law("qp")(lam=1.0, dt=0.1, **kw)
    assert any(s.startswith("solver: active-set") for s in res.diagnostics.notes)
    assert np.all(np.abs(res.qdot) <= 10.0 + 1e-12)
    ref = paper_law("qp", solver="scipy")(lam=1.0, dt=0.1, **kw)
    assert any("scipy" in s for s in ref.diagnostics.notes)
    assert np.allclose(res.qdot, ref.qdot, rtol=1e-9, atol=1e-9)
    with pytest.raises(ConfigurationError, match="not installed"):
        make_law("qp", solver="daqp")


def test_qp_bad_options() -> None:
    for kwargs, word in (
        ({"k_p": 0.0}, "k_p"),
        ({"k_p": 1.5}, "k_p"),
        ({"margin": -0.1}, "margin"),
        ({"margin": 0.5}, "margin"),
        ({"eps": 0.0}, "eps"),
        ({"v_max": 0.0}, "v_max"),
        ({"solver": "no-such-solver"}, "solver"),
        ({"tolerance": 1.0}, "no option"),
    ):
        with pytest.raises(ConfigurationError, match=word):
            make_law("qp", **kwargs)


# -- large-projection -----------------------------------------------------------------------------


def sigmoid(x: float, x0: float, x1: float) -> float:
    return 1.0 / (1.0 + math.exp(-12.0 * (x - x0) / (x1 - x0) + 6.0))


@SETTINGS
@given(p=problems(), square=st.booleans())
def test_norm_projector_is_an_orthogonal_projector_preserving_the_error_norm(
    p: Problem, square: bool
) -> None:
    J1 = np.random.default_rng(1).normal(size=(p.J1.shape[1],) * 2) if square else p.J1
    e1 = np.random.default_rng(2).normal(size=J1.shape[0])
    P, degenerate = norm_projector(J1, e1)
    n = J1.shape[1]
    assert not degenerate
    assert np.allclose(P, P.T) and np.allclose(P @ P, P, atol=1e-12)
    assert np.linalg.matrix_rank(P, tol=1e-9) == n - 1
    assert np.allclose(e1 @ J1 @ P, 0.0, atol=1e-10 * np.linalg.norm(J1.T @ e1))


@SETTINGS
@given(p=problems(), e_norm=st.floats(0.0, 1.0))
def test_switched_projector_annihilates_the_error_direction(p: Problem, e_norm: float) -> None:
    e1 = p.e1 / np.linalg.norm(p.e1) * e_norm if np.linalg.norm(p.e1) > 0 else p.e1
    proj = switched_projector(p.J1, e1, e0=0.1, e_switch=0.7)
    e_n = float(np.linalg.norm(e1))
    expected_lam = 1.0 if e_n > 0.7 else 0.0 if e_n < 0.1 else sigmoid(e_n, 0.1, 0.7)
    assert proj.switching == pytest.approx(expected_lam, abs=1e-12)
    scale = 1.0 + np.linalg.norm(p.J1) * (np.linalg.norm(e1) + 1e-300)
    assert np.allclose(e1 @ p.J1 @ proj.P, 0.0, atol=1e-10 * scale)
    assert proj.rank == np.linalg.matrix_rank(proj.P, tol=1e-9)


def test_switching_value_landmarks() -> None:
    law = paper_law("large-projection", e0=0.2, e1=1.0)
    limits = JointLimits(-np.ones(3), np.ones(3))
    J1 = np.eye(2, 3)
    for e_norm, lam_e in ((0.1, 0.0), (0.2, 1 / (1 + math.exp(6))), (0.6, 0.5), (1.5, 1.0)):
        res = law(J1=J1, e1=[e_norm, 0.0], q=np.zeros(3), limits=limits, lam=1.0, dt=0.1)
        assert res.diagnostics.alpha == pytest.approx(lam_e, rel=1e-12, abs=1e-15)


@SETTINGS
@given(p=problems(), square=st.booleans(), with_secondary=st.booleans())
def test_large_projection_error_norm_decays_as_classical(
    p: Problem, square: bool, with_secondary: bool
) -> None:
    if square:
        p.J1 = np.random.default_rng(5).normal(size=(p.J1.shape[1],) * 2)
        p.e1 = np.random.default_rng(6).normal(size=p.J1.shape[0])
    secondary = np.linspace(-1.0, 1.0, p.J1.shape[1]) if with_secondary else None
    res = paper_law("large-projection")(**p.kwargs(), secondary=secondary)
    rate = p.e1 @ p.J1 @ res.qdot
    expected = -p.lam * float(p.e1 @ p.e1)
    assert rate == pytest.approx(expected, rel=1e-7, abs=1e-9 * (1 + np.abs(res.qdot).max()))


@SETTINGS
@given(p=problems(at_limits=False))
def test_large_projection_reduces_to_classical_far_from_the_limits(p: Problem) -> None:
    frac = np.clip((p.q - p.limits.q_min) / p.limits.range, 0.11, 0.89)  # inside the l0 band
    p.q = p.limits.q_min + frac * p.limits.range
    res = paper_law("large-projection")(**p.kwargs())
    assert np.allclose(res.qdot, classical_qdot(p.J1, p.e1, p.lam), rtol=1e-9, atol=1e-12)
    assert res.diagnostics.critical == ()


@SETTINGS
@given(seed=seeds, where=st.floats(1e-3, 1.0), upper=st.booleans(), e_big=st.booleans())
def test_large_projection_joint_limit_term_on_a_single_joint(
    seed: int, where: float, upper: bool, e_big: bool
) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 7))
    m = int(rng.integers(1, n))
    J1 = rng.normal(size=(m, n))
    e1 = rng.normal(size=m)
    e1 *= (2.0 if e_big else 0.05) / np.linalg.norm(e1)  # λ(‖e‖) = 1 or 0
    limits = JointLimits(-np.ones(n), np.ones(n))
    rho, rho1, tune = 0.1, 0.3, 0.7
    # joint 0 between l0 (0.8) and beyond l1 (0.86), up to the limit
    depth = where * 0.2
    if abs(depth - 0.06) < 1e-9:
        return  # exactly at l1: the sigmoid (0.9975) and the "beyond" branch (1) differ there
    q = np.zeros(n)
    q[0] = 0.8 + depth if upper else -0.8 - depth
    sign = 1.0 if upper else -1.0
    res = paper_law("large-projection", rho=rho, rho1=rho1, lambda_tune=tune)(
        J1=J1, e1=e1, q=q, limits=limits, lam=1.0, dt=0.1
    )
    qdot1 = classical_qdot(J1, e1, 1.0)
    if e_big:
        v = J1.T @ e1
        P = np.eye(n) - np.outer(v, v) / (v @ v)
    else:
        P = np.eye(n) - np.linalg.pinv(J1) @ J1
    beyond = depth >= rho * rho1 * 2.0
    lam_l = 1.0 if beyond else sigmoid(abs(q[0]), 0.8, 0.86)
    b = abs(qdot1[0]) / P[0, 0]
    if not beyond:
        b = min(b, 1.0)
    expected = qdot1 - lam_l * (1 + tune) * b * sign * P[:, 0]
    assert res.diagnostics.critical == ((0,),)
    assert np.allclose(res.qdot, expected, rtol=1e-9, atol=1e-12)
    if beyond:  # the motion toward the limit is reversed
        assert res.qdot[0] == pytest.approx(qdot1[0] - (1 + tune) * abs(qdot1[0]) * sign, abs=1e-9)
        assert sign * res.qdot[0] <= 1e-12


def test_large_projection_with_vanishing_p_ii_stays_finite() -> None:
    # square full-rank J1 near convergence: P = I - J⁺J = 0, so (P g_i)_i = 0 and b := 1
    rng = np.random.default_rng(4)
    J1 = rng.normal(size=(4, 4))
    limits = JointLimits(-np.ones(4), np.ones(4))
    q = np.array([0.99, 0.0, -0.99, 0.0])
    res = paper_law("large-projection")(
        J1=J1, e1=np.full(4, 0.01), q=q, limits=limits, lam=1.0, dt=0.1
    )
    assert np.all(np.isfinite(res.qdot))
    assert res.diagnostics.alpha == 0.0 and res.diagnostics.projector_rank == 0
    assert np.allclose(res.qdot, np.linalg.solve(J1, -np.full(4, 0.01)))


def test_large_projection_bad_options() -> None:
    for kwargs, word in (
        ({"e0": 0.5, "e1": 0.5}, "e0 < e1"),
        ({"e0": -0.1}, r"^e0 .* must be a finite number in \[0, inf\)"),
        ({"rho": 0.5}, "rho"),
        ({"rho1": 1.0}, "rho1"),
        ({"lambda_tune": -1.0}, "lambda_tune"),
        ({"projector": "oblique"}, "projector"),
    ):
        with pytest.raises(ConfigurationError, match=word):
            make_law("large-projection", **kwargs)


# -- degenerate inputs, all baselines ---------------------------------------------------------------


@st.composite
def degenerate_problems(draw: st.DrawFn) -> Problem:
    rng = np.random.default_rng(draw(seeds))
    n = draw(st.integers(1, 6))
    kind = draw(st.sampled_from(["deficient", "zero", "square", "tall", "tiny-sigma"]))
    m = {"square": n, "tall": n + 2}.get(kind, int(rng.integers(1, n + 1)))
    if kind == "deficient":
        r = int(rng.integers(0, min(m, n)))
        J1 = rng.normal(size=(m, r)) @ rng.normal(size=(r, n))
    elif kind == "zero":
        J1 = np.zeros((m, n))
    elif kind == "tiny-sigma":
        J1 = rng.normal(size=(m, n))
        U, s, Vt = np.linalg.svd(J1, full_matrices=False)
        s[-1] = 1e-12 * s[0]
        J1 = (U * s) @ Vt
    else:
        J1 = rng.normal(size=(m, n))
    e1 = np.zeros(m) if draw(st.booleans()) else rng.normal(size=m) * 10.0
    limits = random_limits(rng, n)
    frac = rng.choice([0.0, 1.0, 0.5, 1e-12], size=n)  # exactly at a limit, or almost
    q = np.clip(limits.q_min + frac * limits.range, limits.q_min, limits.q_max)
    return Problem(
        J1, e1, q, limits, draw(st.floats(0.05, 3.0)), draw(st.sampled_from([0.001, 0.04]))
    )


@settings(max_examples=40, deadline=None)
@given(p=degenerate_problems(), with_secondary=st.booleans())
@pytest.mark.parametrize("name", BASELINES)
def test_degenerate_inputs_give_finite_velocities(
    name: str, p: Problem, with_secondary: bool
) -> None:
    secondary = np.ones(p.J1.shape[1]) if with_secondary else None
    res = paper_law(name)(**p.kwargs(), secondary=secondary)
    assert res.qdot.shape == (p.J1.shape[1],)
    assert np.all(np.isfinite(res.qdot))
    assert not any("non-finite" in s for s in res.diagnostics.notes)
    if name in ("sns", "qp"):
        assert_stays_within_limits(p, res.qdot)
