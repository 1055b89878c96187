"""The safety layer (docs/safety.md; issue 8 items 9-10): properties of every law, unit tests.

The property tests are the fast version of ``benchmarks/fuzz_laws.py`` (a few hundred
examples): every method of :data:`redservo.METHODS` with its defaults (shield on, robust
on) on random and degenerate inputs. The checks are exact in float64 where the layer
promises exactness (velocity limits, the position shield).
"""

from __future__ import annotations

import itertools
import math
import re
import warnings
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import redservo
from redservo import (
    METHODS,
    AdaptiveGain,
    ConfigurationError,
    Flag,
    JointLimitError,
    JointLimits,
    ShapeError,
    make_law,
)
from redservo.redundancy.large_projection import P_FILTER, switched_projector
from redservo.redundancy.safety import (
    apply_safety,
    command_box,
    exact_position_fix,
    position_box,
    rate_box,
    scale_into_box,
)

LAWS = {name: make_law(name) for name in METHODS}
ITERATIVE = ("iterative-basic", "iterative", "iterative-smooth", "iterative-smooth-e2")
NULL_SPACE = ("classical", "gpm", "gpm-auto", *ITERATIVE)
SAFETY_FLAGS = {
    Flag.VELOCITY_SCALED,
    Flag.ACCELERATION_LIMITED,
    Flag.ACCELERATION_EXCEEDED,
    Flag.SHIELD_ACTED,
    Flag.NON_FINITE_REPLACED,
}
PLACES = ("inside", "threshold", "limit", "safe", "band", "critical", "ulp", "beyond", "centre")


# -- strategies -----------------------------------------------------------------------------------


def _jacobian(rng: np.random.Generator, m: int, n: int, kind: str, cond: float) -> np.ndarray:
    if kind in ("ill", "well"):
        cond = min(cond, 1e2) if kind == "well" else cond
        k = min(m, n)
        U = np.linalg.qr(rng.normal(size=(m, m)))[0]
        V = np.linalg.qr(rng.normal(size=(n, n)))[0]
        S = np.zeros((m, n))
        S[range(k), range(k)] = np.logspace(0, -math.log10(cond), k)
        return np.asarray(U @ S @ V.T)
    J = rng.normal(size=(m, n))
    if kind == "dup" and m >= 2:
        J[m - 1] = -2.0 * J[0]
    elif kind == "zero-row":
        J[rng.integers(0, m)] = 0.0
    elif kind == "zero-col":
        J[:, rng.integers(0, n)] = 0.0
    return J


def _place(rng: np.random.Generator, lim: JointLimits, i: int, place: str) -> float:
    up = bool(rng.random() < 0.5)
    hard = lim.q_max[i] if up else lim.q_min[i]
    safe = lim.safe_max[i] if up else lim.safe_min[i]
    thr = lim.q_tilde_max[i] if up else lim.q_tilde_min[i]
    out = 1.0 if up else -1.0
    if place == "threshold":
        return float(thr)
    if place == "limit":
        return float(hard)
    if place == "safe":
        return float(safe)
    if place == "band":
        return float(safe + rng.uniform(0.0, 1.0) * (hard - safe))
    if place == "critical":
        return float(thr + rng.uniform(0.0, 1.0) * (safe - thr))
    if place == "ulp":
        return float(np.nextafter(safe, safe + out * rng.choice([-1.0, 1.0])))
    if place == "beyond":
        return float(hard + out * rng.uniform(0.0, 0.9e-9))
    if place == "centre":
        return float(lim.center[i])
    return float(rng.uniform(lim.q_tilde_min[i], lim.q_tilde_max[i]))


@st.composite
def cases(
    draw: Any,
    *,
    jkinds: tuple[str, ...] = ("random", "dup", "zero-row", "zero-col", "ill", "well"),
    places: tuple[str, ...] = PLACES,
    scales: bool = True,
    redundant: bool = False,
    prev: bool = True,
    accel: bool = True,
) -> dict[str, Any]:
    """Valid law inputs: random and degenerate ``J1``, joints at special places, limits
    with and without rates and margin, gains, periods, feed-forward, secondary, ``qdot_prev``."""
    n = draw(st.integers(2, 9))
    m = draw(st.integers(1, n - 1)) if redundant else draw(st.integers(1, 8))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    cond = 10.0 ** draw(st.integers(0, 2 if draw(st.booleans()) else 16))
    J = _jacobian(rng, m, n, draw(st.sampled_from(jkinds)), cond)
    J *= 10.0 ** draw(st.integers(-12, 12) if scales else st.integers(-1, 1))
    width = 10.0 ** rng.uniform(-2, 1.5, n)
    lo = rng.uniform(-10, 10, n) - width * rng.uniform(0.1, 0.9, n)
    rho = draw(st.sampled_from([0.02, 0.1, 0.25, 0.45]))
    kw: dict[str, Any] = {}
    if draw(st.booleans()):
        kw["qdot_max"] = 10.0 ** rng.uniform(-3, 1.5, n)
    if accel and draw(st.booleans()):
        kw["qddot_max"] = 10.0 ** rng.uniform(-2, 3, n)
    kw["margin"] = draw(st.sampled_from([0.0, 0.0, 0.01, 0.5])) * rho
    lim = JointLimits(lo, lo + width, rho, **kw)
    q = np.array([_place(rng, lim, i, draw(st.sampled_from(places))) for i in range(n)])
    e1 = rng.normal(size=m) * 10.0 ** draw(st.integers(-12, 12) if scales else st.integers(-2, 0))
    lam: float | AdaptiveGain = 10.0 ** draw(st.floats(-3, math.log10(50.0)))
    if draw(st.booleans()):
        lam = AdaptiveGain(lam, lam * draw(st.floats(0.01, 1.0)), draw(st.floats(0.0, 100.0)))
    qdot_prev = None
    if prev and draw(st.booleans()):
        v = lim.qdot_max
        qdot_prev = rng.uniform(-1, 1, n) * (1.0 if v is None else v)
    big = 12 if scales else 0
    return {
        "J1": J,
        "e1": e1,
        "q": q,
        "limits": lim,
        "lam": lam,
        "dt": 10.0 ** draw(st.floats(-4, math.log10(0.2))),
        "de1_dt": rng.normal(size=m) * 10.0 ** rng.uniform(-12, big)
        if rng.random() < 0.5
        else None,
        "secondary": rng.normal(size=n) * 10.0 ** rng.uniform(-6, big)
        if rng.random() < 0.5
        else None,
        "qdot_prev": qdot_prev,
    }


def gain(kw: dict[str, Any]) -> float:
    """The gain the law uses (an AdaptiveGain evaluated at ‖e1‖∞)."""
    lam = kw["lam"]
    return lam(float(np.max(np.abs(kw["e1"])))) if isinstance(lam, AdaptiveGain) else float(lam)


def assert_safe(qdot: np.ndarray, kw: dict[str, Any], flags: frozenset[Flag], name: str) -> None:
    """The promises of the safety layer (shield on), exact in float64."""
    lim, q, dt, prev = kw["limits"], kw["q"], kw["dt"], kw["qdot_prev"]
    assert np.isfinite(qdot).all(), name
    if lim.qdot_max is not None:
        assert np.all(np.abs(qdot) <= lim.qdot_max), (name, qdot, lim.qdot_max)
    smin, smax = lim.safe_min, lim.safe_max
    nxt = q + dt * qdot
    inside = (q >= smin) & (q <= smax)
    assert not np.any(inside & ((nxt < smin) | (nxt > smax))), (name, q, nxt)
    assert not np.any((q > smax) & (nxt > q)), (name, q, nxt)
    assert not np.any((q < smin) & (nxt < q)), (name, q, nxt)
    a = lim.qddot_max
    if a is not None and prev is not None and Flag.ACCELERATION_EXCEEDED not in flags:
        slack = 4.0 * np.spacing(np.maximum(np.abs(prev), np.abs(qdot))) + 1e-12 * dt * (1 + a)
        assert np.all(np.abs(qdot - prev) <= a * dt + slack), (name, qdot - prev, a * dt)


# -- properties of every law ----------------------------------------------------------------------


@settings(max_examples=150, deadline=None)
@given(cases())
def test_every_law_is_finite_within_rates_and_shielded(kw: dict[str, Any]) -> None:
    for name, law in LAWS.items():
        res = law(**kw)
        assert_safe(res.qdot, kw, res.diagnostics.flags, name)


def unflagged(qdot: np.ndarray) -> float:
    """The largest change the shield makes without raising SHIELD_ACTED (norm, rad/s or m/s).

    It flags changes above ``1e-12 (1 + max|q̇|)`` only (roundoff): a tiny command clamped
    at a limit, or a joint one float step inside its margin band sent back, go unreported.
    """
    return 1e-12 * (1.0 + float(np.abs(qdot).max())) * math.sqrt(qdot.shape[0])


def _zero_in_rate_box(kw: dict[str, Any]) -> bool:
    lo, hi, _ = rate_box(kw["limits"], kw["dt"], kw["qdot_prev"])
    return bool(np.all((lo <= 0.0) & (hi >= 0.0)))


def _scale(kw: dict[str, Any], qdot: np.ndarray) -> float:
    """A magnitude for round-off tolerances: the command and the task terms (rad/s or m/s)."""
    J = kw["J1"]
    task = np.linalg.pinv(J, rcond=1e-8) @ (gain(kw) * kw["e1"])
    if kw["de1_dt"] is not None:
        task = task + np.linalg.pinv(J, rcond=1e-8) @ kw["de1_dt"]
    sec = 0.0 if kw["secondary"] is None else float(np.linalg.norm(kw["secondary"]))
    return float(np.linalg.norm(qdot) + np.linalg.norm(task) + sec)


@settings(max_examples=80, deadline=None)
@given(
    cases(
        jkinds=("well", "random"),
        places=("inside", "critical", "threshold"),
        scales=False,
        redundant=True,
    )
)
def test_stopped_axes_of_the_iterative_family_stay_stopped(kw: dict[str, Any]) -> None:
    """γ_k = 1 axes get q̇_k = 0 unless the safety stage had to change the command; with
    uniform scaling a velocity-scaled command keeps them at 0 (scaled toward 0 ∈ R)."""
    for name in ITERATIVE:
        res = LAWS[name](**kw)
        d = res.diagnostics
        if d.flags & {Flag.DAMPED, Flag.LEAST_SQUARES, Flag.OVERCONSTRAINED}:
            continue  # the constraints are met only approximately (documented)
        if d.flags & (SAFETY_FLAGS - {Flag.VELOCITY_SCALED}):
            continue
        if d.has(Flag.VELOCITY_SCALED) and not _zero_in_rate_box(kw):
            continue  # scaled toward a non-zero anchor (acceleration limit)
        assert d.gamma is not None
        levels = d.critical if name != "iterative-smooth-e2" else d.critical[1:]
        stopped = [k for level in levels for k in level if d.gamma[k] == 1.0]
        tol = 1e-9 * _scale(kw, res.qdot)
        assert np.all(np.abs(res.qdot[stopped]) <= tol), (name, stopped, res.qdot)


@settings(max_examples=80, deadline=None)
@given(cases(jkinds=("well", "random", "ill", "zero-col")))
def test_null_space_laws_keep_the_task(kw: dict[str, Any]) -> None:
    """``J1 q̇ = -λ e1 - ∂e1/∂t`` unless the task inverse was damped or the safety stage acted."""
    target = -gain(kw) * kw["e1"] - (0.0 if kw["de1_dt"] is None else kw["de1_dt"])
    for name in NULL_SPACE:
        res = LAWS[name](**kw)
        if res.diagnostics.flags & (SAFETY_FLAGS | {Flag.DAMPED, Flag.RANK_LOSS}):
            continue
        J = kw["J1"]
        resid = float(np.linalg.norm(J @ res.qdot - target))
        tol = 1e-9 * (np.linalg.norm(J, 2) * _scale(kw, res.qdot) + np.linalg.norm(target))
        tol += np.linalg.norm(J, 2) * unflagged(res.qdot)
        assert resid <= tol, (name, resid, tol)


@settings(max_examples=60, deadline=None)
@given(cases(scales=False))
def test_uniform_scaling_keeps_the_direction(kw: dict[str, Any]) -> None:
    """``q̇ = a + s (q̇_raw - a)`` with ``a`` the point of the rate box closest to 0, when
    the shield did not act. ``sns``, ``qp``, ``qp-goal`` and ``predictive`` put the rate box in
    their own problem."""
    lim = kw["limits"]
    raw_kw = {**kw, "limits": lim.replace(qdot_max=None, qddot_max=None)}  # same margin
    anchor = np.clip(0.0, *rate_box(lim, kw["dt"], kw["qdot_prev"])[:2])
    for name in METHODS:
        if name in ("sns", "qp", "qp-goal", "predictive"):
            continue
        res = LAWS[name](**kw)
        if res.diagnostics.has(Flag.SHIELD_ACTED) or res.diagnostics.has(
            Flag.ACCELERATION_EXCEEDED
        ):
            continue
        raw = make_law(name, shield=False)(**raw_kw).qdot - anchor
        got = res.qdot - anchor
        # parallel and same sense: got = s raw, s in [0, 1]
        s = float(got @ raw) / float(raw @ raw) if raw.any() else 0.0
        assert -1e-9 <= s <= 1.0 + 1e-9, (name, s)
        scale = np.linalg.norm(raw) + np.linalg.norm(anchor)
        assert np.linalg.norm(got - s * raw) <= 1e-9 * scale + unflagged(got), (name, got, raw)


def _small_pii(kw: dict[str, Any], d: redservo.Diagnostics) -> bool:
    """True when large-projection's robust filter on ``|P_ii|`` applies to an activated joint."""
    P = switched_projector(kw["J1"], kw["e1"]).P
    active = list(d.critical[0]) if d.critical else []
    return bool(np.any(np.abs(np.diag(P))[active] < P_FILTER))


@settings(max_examples=60, deadline=None)
@given(cases(jkinds=("well",), scales=False))
def test_robust_changes_nothing_on_well_conditioned_inputs(kw: dict[str, Any]) -> None:
    """No filter acts (no DAMPED flag) → robust on and off give the same command, bit for bit."""
    for name in METHODS:
        on = make_law(name, robust=True)(**kw)
        if on.diagnostics.has(Flag.DAMPED) or np.linalg.cond(kw["J1"]) > 1e2:
            continue
        if name == "large-projection" and _small_pii(kw, on.diagnostics):
            continue  # its |P_ii| filter acted (it raises no DAMPED flag for it)
        off = make_law(name, robust=False)(**kw)
        assert np.array_equal(on.qdot, off.qdot), (name, on.qdot, off.qdot)


# -- apply_safety ---------------------------------------------------------------------------------

LIM2 = JointLimits([-1.0, -1.0], [1.0, 1.0], 0.1)
Q0 = np.zeros(2)


def _events(out: Any) -> dict[Flag, float]:
    return {e.flag: e.value for e in out.events}


def test_apply_safety_replaces_non_finite_commands() -> None:
    out = apply_safety(np.array([np.nan, 1.0]), Q0, LIM2, 0.01)
    assert np.array_equal(out.qdot, [0.0, 0.0])
    assert _events(out) == {Flag.NON_FINITE_REPLACED: 1}


def test_apply_safety_scales_uniformly_into_the_velocity_limits() -> None:
    lim = LIM2.replace(qdot_max=1.0)
    out = apply_safety(np.array([2.0, 1.0]), Q0, lim, 0.01)
    assert np.array_equal(out.qdot, [1.0, 0.5])
    assert _events(out) == {Flag.VELOCITY_SCALED: 0.5}
    inside = apply_safety(np.array([0.5, -1.0]), Q0, lim, 0.01)
    assert np.array_equal(inside.qdot, [0.5, -1.0]) and inside.events == ()


def test_apply_safety_limits_the_acceleration() -> None:
    lim = LIM2.replace(qdot_max=10.0, qddot_max=1.0)
    out = apply_safety(np.array([1.0, 0.5]), Q0, lim, 0.1, qdot_prev=np.zeros(2))
    np.testing.assert_allclose(out.qdot, [0.1, 0.05], rtol=1e-15)
    assert set(_events(out)) == {Flag.ACCELERATION_LIMITED}
    # the rate box excludes 0: the command is scaled toward its point closest to 0
    braking = apply_safety(np.zeros(2), Q0, lim, 0.1, qdot_prev=np.array([1.0, 0.0]))
    np.testing.assert_allclose(braking.qdot, [0.9, 0.0], rtol=1e-15)
    assert Flag.ACCELERATION_LIMITED in _events(braking)


def test_apply_safety_releases_the_acceleration_limit_above_the_velocity_limit() -> None:
    lim = LIM2.replace(qdot_max=1.0, qddot_max=1.0)
    out = apply_safety(np.array([2.0, 0.0]), Q0, lim, 0.1, qdot_prev=np.array([2.0, 0.0]))
    assert np.all(np.abs(out.qdot) <= 1.0)
    assert math.isnan(_events(out)[Flag.ACCELERATION_EXCEEDED])


def test_apply_safety_position_shield() -> None:
    q = np.array([0.99, 0.0])
    out = apply_safety(np.array([1.0, 0.0]), q, LIM2, 0.1)
    assert q[0] + 0.1 * out.qdot[0] <= 1.0
    assert out.qdot[0] == pytest.approx(0.1, rel=1e-12)
    assert _events(out)[Flag.SHIELD_ACTED] == pytest.approx(0.9, rel=1e-12)
    off = apply_safety(np.array([1.0, 0.0]), q, LIM2, 0.1, shield=False)
    assert np.array_equal(off.qdot, [1.0, 0.0]) and off.events == ()


def test_apply_safety_position_wins_over_the_acceleration_limit() -> None:
    """At the safe limit, moving toward it at v with a small q̈_max: the joint is stopped."""
    lim = LIM2.replace(qdot_max=1.0, qddot_max=0.5)
    q = np.array([1.0, 0.0])
    out = apply_safety(np.array([1.0, 0.0]), q, lim, 0.01, qdot_prev=np.array([1.0, 0.0]))
    assert q[0] + 0.01 * out.qdot[0] <= 1.0
    assert Flag.ACCELERATION_EXCEEDED in _events(out)


def test_apply_safety_secondary_first_scales_the_rest_before_the_task() -> None:
    lim = LIM2.replace(qdot_max=1.0)
    raw, task = np.array([0.5, 3.0]), np.array([0.5, 0.0])
    first = apply_safety(raw, Q0, lim, 0.01, task=task)
    np.testing.assert_allclose(first.qdot, [0.5, 1.0], rtol=1e-15)
    uniform = apply_safety(raw, Q0, lim, 0.01)
    np.testing.assert_allclose(uniform.qdot, [1.0 / 6.0, 1.0], rtol=1e-15)


def test_secondary_first_law_keeps_the_task_when_it_fits() -> None:
    rng = np.random.default_rng(3)
    J, e1 = rng.normal(size=(2, 5)), 0.1 * rng.normal(size=2)
    lim = JointLimits(-np.ones(5), np.ones(5), qdot_max=1.0)
    kw = {"J1": J, "e1": e1, "q": np.zeros(5), "limits": lim, "lam": 1.0, "dt": 0.01}
    sec = 50.0 * rng.normal(size=5)
    res = make_law("classical", scaling="secondary-first")(**kw, secondary=sec)
    assert res.diagnostics.has(Flag.VELOCITY_SCALED)
    np.testing.assert_allclose(J @ res.qdot, -e1, atol=1e-12)
    uniform = make_law("classical")(**kw, secondary=sec)
    assert np.linalg.norm(J @ uniform.qdot + e1) > 1e-3  # uniform scaling shrinks the task too


# -- scale_into_box, exact_position_fix, position_box, command_box --------------------------------


def test_scale_into_box() -> None:
    lo, hi = -np.ones(2), np.ones(2)
    same, s = scale_into_box(np.array([0.5, -1.0]), lo, hi)
    assert np.array_equal(same, [0.5, -1.0]) and s == 1.0
    out, s = scale_into_box(np.array([2.0, -4.0]), lo, hi)
    assert np.array_equal(out, [0.5, -1.0]) and s == 0.25
    # box excluding 0: q̇ = a + s (q̇_des - a) with a = 0.5 the point closest to 0
    out, s = scale_into_box(np.array([2.0]), np.array([0.5]), np.array([1.0]))
    assert out[0] == 1.0 and s == pytest.approx(1.0 / 3.0)
    # secondary-first: the task fits, the rest is scaled
    out, s = scale_into_box(np.array([0.5, 3.0]), lo, hi, task=np.array([0.5, 0.0]))
    np.testing.assert_allclose(out, [0.5, 1.0])
    assert s == pytest.approx(1.0 / 3.0)
    # the task alone does not fit: it is scaled and the rest dropped
    out, s = scale_into_box(np.array([2.0, 3.0]), lo, hi, task=np.array([2.0, 0.0]))
    np.testing.assert_allclose(out, [1.0, 0.0])
    assert s == 0.5


def test_exact_position_fix_moves_by_float_steps() -> None:
    lim = JointLimits([-3.0], [0.3])
    q, dt = np.array([-1.311]), 0.003
    qdot = (0.3 - q) / dt  # 537.0, and q + dt * 537.0 = 0.30000000000000004 > 0.3
    assert q[0] + dt * qdot[0] > 0.3
    fixed = exact_position_fix(q, qdot, dt, lim)
    assert fixed[0] == np.nextafter(qdot[0], -np.inf)
    assert q[0] + dt * fixed[0] <= 0.3
    mirror = exact_position_fix(-q, -qdot, dt, JointLimits([-0.3], [3.0]))
    assert mirror[0] == -fixed[0] and -q[0] + dt * mirror[0] >= -0.3
    ok = np.array([100.0])
    assert exact_position_fix(q, ok, dt, lim) is ok  # nothing to do: the same array


def test_exact_position_fix_lets_a_joint_in_the_margin_band_stay() -> None:
    lim = JointLimits([-1.0], [1.0], margin=0.05)  # safe_max = 0.9
    q = np.array([0.95])
    assert exact_position_fix(q, np.zeros(1), 0.1, lim)[0] == 0.0
    nudged = exact_position_fix(q, np.array([1e-300]), 0.1, lim)
    assert q[0] + 0.1 * nudged[0] <= q[0]


def test_position_box() -> None:
    lim = JointLimits([-1.0], [1.0], margin=0.05)  # safe limits ±0.9
    dt = 0.1
    lo, hi = position_box(np.array([0.5]), lim, dt)
    assert lo[0] == pytest.approx(-14.0) and hi[0] == pytest.approx(4.0)
    # in the upper margin band: no motion further out; without a velocity limit it may stay
    lo, hi = position_box(np.array([0.95]), lim, dt)
    assert hi[0] == 0.0 and lo[0] < 0.0
    # with one it retreats, at most at v (here slower than the one-step return -0.5 rad/s)
    for v, expect in ((0.2, -0.2), (10.0, (0.9 - 0.95) / dt)):
        lo, hi = position_box(np.array([0.95]), lim.replace(qdot_max=v), dt)
        assert hi[0] == pytest.approx(expect) and -v <= hi[0] < 0.0 and lo[0] <= hi[0]
    lo, hi = position_box(np.array([-0.95]), lim.replace(qdot_max=0.2), dt)
    assert lo[0] == pytest.approx(0.2) and lo[0] <= hi[0]
    # braking bound, discrete time: q̇ <= √(h² + 2 a (d - a dt²/8)) - h, h = a dt/2; close to
    # √(2 a d) for a short period
    a, dt, d = 2.0, 0.001, 0.01
    lo, hi = position_box(np.array([0.89]), lim.replace(qddot_max=a), dt)
    half = 0.5 * a * dt
    assert hi[0] == pytest.approx(math.sqrt(half**2 + 2 * a * (d - a * dt**2 / 8)) - half)
    assert hi[0] == pytest.approx(math.sqrt(2.0 * a * d), rel=1e-2)


def test_braking_from_the_bound_keeps_the_acceleration_limit() -> None:
    """Start at the braking bound and brake at q̈_max: the joint stops within its safe limit
    (the continuous √(2 a d) overshoots in discrete time)."""
    lim = JointLimits([-1.0], [1.0], margin=0.05, qddot_max=12.5, qdot_max=10.0)
    dt = 0.04
    for q0 in (0.0, 0.5, 0.7, 0.85):
        q = np.array([q0])
        v = float(position_box(q, lim, dt)[1][0])
        while v > 0.0:
            q = q + dt * v
            assert q[0] <= lim.safe_max[0] + 1e-12
            hi = float(position_box(q, lim, dt)[1][0])
            assert hi >= v - 12.5 * dt - 1e-12  # braking at q̈_max stays feasible
            v = max(v - 12.5 * dt, 0.0)


def test_command_box_prefers_the_position_to_the_acceleration() -> None:
    lim = LIM2.replace(qdot_max=1.0, qddot_max=0.5)
    lo, hi = command_box(np.array([1.0, 0.0]), lim, 0.01, np.array([1.0, 0.0]))
    # the acceleration box [0.995, 1] misses P = [-1, 0]: the position wins, and the box is
    # the edge of P nearest to it (the acceleration limit broken as little as possible)
    assert hi[0] == 0.0 and lo[0] == 0.0
    assert lo[1] == pytest.approx(-0.005) and hi[1] == pytest.approx(0.005)


# -- AdaptiveGain ---------------------------------------------------------------------------------


def test_adaptive_gain_shape() -> None:
    g = AdaptiveGain(zero=4.0, inf=0.4, slope=30.0)
    assert g(0.0) == 4.0
    assert g(1e6) == pytest.approx(0.4, abs=1e-12)
    h = 1e-7
    assert (g(h) - g(0.0)) / h == pytest.approx(-30.0, rel=1e-5)
    values = [g(x) for x in np.logspace(-6, 3, 200)]
    assert all(b <= a for a, b in itertools.pairwise(values))
    assert AdaptiveGain(2.0, 2.0, 5.0)(1.0) == 2.0  # λ0 = λ∞: constant
    assert AdaptiveGain(2.0, 0.5, 0.0)(1.0) == 2.0  # no slope: λ0


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"zero": 1.0, "inf": 2.0, "slope": 1.0}, "inf"),
        ({"zero": 1.0, "inf": 0.5, "slope": -1.0}, "slope"),
        ({"zero": "1", "inf": 0.5, "slope": 1.0}, "zero"),
        ({"zero": 1.0, "inf": math.nan, "slope": 1.0}, "inf"),
        ({"zero": 0.0, "inf": 0.0, "slope": 1.0}, "inf"),
    ],
)
def test_adaptive_gain_rejects_bad_values(kwargs: dict[str, Any], argument: str) -> None:
    with pytest.raises(ConfigurationError) as info:
        AdaptiveGain(**kwargs)
    assert info.value.argument == argument


@pytest.mark.parametrize("name", METHODS)
def test_adaptive_gain_is_evaluated_at_the_error_norm(name: str) -> None:
    rng = np.random.default_rng(7)
    g = AdaptiveGain(2.0, 0.2, 10.0)
    e1 = 0.1 * rng.normal(size=2)
    kw = {"J1": rng.normal(size=(2, 6)), "e1": e1, "q": np.full(6, 0.85), "dt": 0.04}
    kw["limits"] = JointLimits(-np.ones(6), np.ones(6), qdot_max=2.0)
    a = make_law(name)(**kw, lam=g).qdot
    b = make_law(name)(**kw, lam=g(float(np.max(np.abs(e1))))).qdot
    assert np.array_equal(a, b)


# -- bad arguments (issue 8 item 10) ----------------------------------------------------------------


def _good() -> dict[str, Any]:
    return {
        "J1": np.eye(2, 3),
        "e1": np.ones(2),
        "q": np.zeros(3),
        "limits": JointLimits(-np.ones(3), np.ones(3)),
        "lam": 0.5,
        "dt": 0.01,
    }


@pytest.mark.parametrize("argument", ["lam", "dt"])
@pytest.mark.parametrize("value", [None, "0.5", np.array([0.5]), [0.5]])
def test_gain_and_period_must_be_numbers(argument: str, value: object) -> None:
    with pytest.raises(ConfigurationError) as info:
        make_law("classical")(**{**_good(), argument: value})
    assert isinstance(info.value, redservo.RedservoError)
    assert info.value.argument == argument and str(info.value).startswith(argument)


@pytest.mark.parametrize("value", [None, "0.1"])
def test_rho_must_be_a_number(value: object) -> None:
    with pytest.raises(ConfigurationError) as info:
        JointLimits(-np.ones(3), np.ones(3), rho=value)  # type: ignore[arg-type]
    assert info.value.argument == "rho" and "rho" in str(info.value)


@pytest.mark.parametrize("J1", [np.eye(2, 3) * (1 + 1j), np.eye(2, 3).astype(complex)])
def test_complex_jacobian_is_rejected(J1: np.ndarray) -> None:
    with pytest.raises(ShapeError) as info:
        make_law("classical")(**{**_good(), "J1": J1})
    assert info.value.argument == "J1" and "complex" in str(info.value)


@pytest.mark.parametrize("bounds", [(-1e308, 1e308), (0.0, 1e308), (-1e300, 0.0)])
def test_limits_whose_range_overflows(bounds: tuple[float, float]) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy overflow warning on the way
        with pytest.raises(JointLimitError) as info:
            JointLimits([bounds[0], -1.0], [bounds[1], 1.0])
    exc = info.value
    assert exc.argument in ("q_min", "q_max") and exc.joint == 0
    assert (exc.lower, exc.upper) == bounds


@pytest.mark.parametrize(("joint", "value"), [(1, 1.0 + 2.5e-9), (0, -1.0 - 1.2345678901e-7)])
def test_q_past_a_limit_reports_the_excess_in_full(joint: int, value: float) -> None:
    q = np.zeros(3)
    q[joint] = value
    with pytest.raises(JointLimitError) as info:
        make_law("classical")(**{**_good(), "q": q})
    exc = info.value
    assert (exc.argument, exc.joint, exc.value, exc.lower, exc.upper) == (
        "q",
        joint,
        value,
        -1.0,
        1.0,
    )
    excess = value - 1.0 if value > 0 else -1.0 - value
    message = str(exc)
    assert repr(value) in message and repr(excess) in message
    assert re.search(r"by [0-9.e+-]{12,}", message)  # full digits, not 3 significant ones


def test_a_joint_pinned_by_braking_does_not_stop_the_others() -> None:
    """When the acceleration and position boxes of a braking joint touch (a single point), the
    uniform scaling pins that joint and still moves the others (no stop-and-go)."""
    lo = np.array([-1.0, -0.2, -0.111479])
    hi = np.array([1.0, 0.2, -0.111479])
    out, s = scale_into_box(np.array([0.5, 0.1, -0.3]), lo, hi)
    assert out[2] == -0.111479
    assert s == 1.0 and out[0] == 0.5 and out[1] == 0.1
