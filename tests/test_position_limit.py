"""The position limit is never given up without a flag (issue 17 item 5; docs/safety.md).

With the shield off but rate limits on, a previous command too fast to stop within
``q̈_max dt`` leaves no command within the rate limits that keeps a joint inside its hard
limits. Every law then reports ``POSITION_LIMIT_UNAVOIDABLE`` (joint and distance), from the
common safety stage; ``sns`` and ``qp`` cross by as little as the rate limits allow, and never
cross when some command within the rate limits would not. The compiled campaign loop raises
the same flag.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo import METHODS, Flag, JointLimits, make_law
from redservo.redundancy.safety import apply_safety, command_box, rate_box

UNAVOIDABLE = Flag.POSITION_LIMIT_UNAVOIDABLE
LIM3 = JointLimits([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.1, qdot_max=2.0, qddot_max=0.01)
J3 = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]])


def _case(dt: float) -> dict[str, Any]:
    """Joint 0 at 0.5 rad moving at 1.9 rad/s toward its upper limit 1 rad; q̈_max = 0.01:
    within one period it can slow down to 1.9 - 0.01 dt rad/s at best."""
    return {
        "J1": J3,
        "e1": np.array([0.1, -0.2]),
        "q": np.array([0.5, 0.0, 0.0]),
        "limits": LIM3,
        "lam": 1.0,
        "dt": dt,
        "qdot_prev": np.array([1.9, 0.0, 0.0]),
    }


# -- the reproducers --------------------------------------------------------------------------


@pytest.mark.parametrize("dt", [10.0, 1.0])
@pytest.mark.parametrize("name", METHODS)
def test_every_law_flags_an_unavoidable_crossing(name: str, dt: float) -> None:
    kw = _case(dt)
    res = make_law(name, shield=False)(**kw)
    nxt = kw["q"] + dt * res.qdot
    best = 0.5 + dt * (1.9 - 0.01 * dt)  # the slowest the rate limits allow
    assert nxt[0] >= best - 1e-12 and best > 1.0  # it crosses, as it must
    d = res.diagnostics
    assert d.has(UNAVOIDABLE), d.flags
    assert d.value(UNAVOIDABLE) == nxt[0] - 1.0  # the distance past the hard limit
    message = next(e.message for e in d.events if e.flag is UNAVOIDABLE)
    assert message.startswith("joint 0 passes its upper limit")
    assert abs(res.qdot[0] - 1.9) <= 0.01 * dt * (1 + 1e-12)  # the rate limits held
    assert np.all(np.abs(res.qdot) <= 2.0)


@pytest.mark.parametrize("dt", [10.0, 1.0])
@pytest.mark.parametrize("name", ["sns", "qp"])
def test_sns_and_qp_cross_by_as_little_as_the_rate_limits_allow(name: str, dt: float) -> None:
    """They plan with the rate box's edge nearest the limit: the crossing joint gets exactly
    the slowest velocity the acceleration limit allows, and nothing rescales the command
    afterwards (no ``acceleration-limited``: the others keep what the law gave them)."""
    kw = _case(dt)
    res = make_law(name, shield=False)(**kw)
    assert res.qdot[0] == 1.9 - 0.01 * dt
    assert not res.diagnostics.has(Flag.ACCELERATION_LIMITED)
    assert np.all(np.abs(res.qdot[1:] - 0.0) <= 0.01 * dt * (1 + 1e-12))


@pytest.mark.parametrize("name", METHODS)
def test_with_the_shield_on_the_position_wins_and_nothing_crosses(name: str) -> None:
    kw = _case(10.0)
    res = make_law(name)(**kw)
    nxt = kw["q"] + kw["dt"] * res.qdot
    assert np.all(nxt <= 1.0) and np.all(nxt >= -1.0)
    assert not res.diagnostics.has(UNAVOIDABLE)
    assert res.diagnostics.has(Flag.ACCELERATION_EXCEEDED)


def test_a_crossing_the_law_chose_is_not_flagged_unavoidable() -> None:
    """Shield off, a command that crosses although stopping was possible: the law's own choice
    (the paper laws as printed), not flagged; the flag is for what no command could avoid."""
    lim = LIM3.replace(qddot_max=100.0)
    out = apply_safety(np.array([1.0, 0.0, 0.0]), np.array([0.95, 0, 0]), lim, 0.1, shield=False)
    assert out.qdot[0] == 1.0 and not any(e.flag is UNAVOIDABLE for e in out.events)


def test_the_velocity_limit_outranks_the_position_with_the_shield_on() -> None:
    """A joint 1e-10 rad beyond its limit (valid input) with an absurdly small velocity limit
    and a period of 1e-4 s: no command brings it back inside; still never moved further out."""
    lim = JointLimits([-1.0], [1.0], qdot_max=1e-7)
    q = np.array([1.0 + 1e-10])
    out = apply_safety(np.array([5.0]), q, lim, 1e-4)
    assert q[0] + 1e-4 * out.qdot[0] <= q[0]
    assert not any(e.flag is UNAVOIDABLE for e in out.events)  # not taken further out


def test_command_box_without_the_shield_lets_the_rate_limits_win() -> None:
    lim = JointLimits([-1.0, -1.0], [1.0, 1.0], qdot_max=1.0, qddot_max=0.5)
    q, prev = np.array([1.0, -1.0]), np.array([1.0, -1.0])
    lo, hi = command_box(q, lim, 0.01, prev, shield=False)
    assert lo[0] == hi[0] == 1.0 - 0.005  # the slowest it can go
    assert lo[1] == hi[1] == -1.0 + 0.005
    lo, hi = command_box(q, lim, 0.01, prev)  # shield on: the position wins
    assert lo[0] == hi[0] == 0.0 and lo[1] == hi[1] == 0.0


@pytest.mark.parametrize("name", ["sns", "qp"])
def test_an_empty_position_box_does_not_send_the_joint_across(name: str) -> None:
    """Joint 0 in its upper margin band (must come back) and within ``q̈_max dt²/8`` of its
    lower safe limit (may not move down, the braking bound): the shield's box is empty. The
    shield's choice (come back at the band's rate) lies within the rate limits, so without
    the shield too the joint gets it; it was sent up at the velocity limit, across its hard
    limit (found by benchmarks/fuzz_laws.py --shield-off)."""
    lim = JointLimits([0.0, -1.0], [1.0, 1.0], 0.1, margin=0.05, qdot_max=2.0, qddot_max=100.0)
    q, dt = np.array([0.97, 0.0]), 0.3
    kw = {"J1": np.array([[1.0, 0.1]]), "e1": np.array([-1.0]), "limits": lim, "lam": 1.0}
    res = make_law(name, shield=False)(**kw, q=q, dt=dt, qdot_prev=np.zeros(2))
    assert res.qdot[0] == (0.95 - 0.97) / dt
    assert not res.diagnostics.has(UNAVOIDABLE)


# -- properties -------------------------------------------------------------------------------


@st.composite
def racing(draw: Any) -> dict[str, Any]:
    """Shield-off inputs with rate limits where joints race toward their limits: positions
    anywhere (band, limit, margin), previous commands up to the velocity limit, periods up to
    10 s, small acceleration limits (stopping often impossible, often possible)."""
    n = draw(st.integers(2, 7))
    m = draw(st.integers(1, n))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    width = 10.0 ** rng.uniform(-2, 1, n)
    lo = rng.uniform(-3, 3, n)
    rho = 0.1
    margin = draw(st.sampled_from([0.0, 0.01, 0.05]))
    lim = JointLimits(
        lo,
        lo + width,
        rho,
        qdot_max=10.0 ** rng.uniform(-1, 1, n),
        qddot_max=10.0 ** rng.uniform(-3, 2, n),
        margin=margin,
    )
    u = rng.uniform(0, 1, n) ** draw(st.sampled_from([1.0, 5.0]))  # often near a limit
    up = rng.random(n) < 0.5
    q = np.where(up, lim.q_max - u * 0.5 * lim.range, lim.q_min + u * 0.5 * lim.range)
    prev = rng.uniform(-1, 1, n) * lim.qdot_max
    prev = np.where(rng.random(n) < 0.5, np.where(up, 1.0, -1.0) * np.abs(prev), prev)
    return {
        "J1": rng.normal(size=(m, n)),
        "e1": rng.normal(size=m) * 10.0 ** rng.uniform(-2, 1),
        "q": q,
        "limits": lim,
        "lam": float(10.0 ** rng.uniform(-1, 1)),
        "dt": float(10.0 ** draw(st.floats(-3, 1))),
        "secondary": rng.normal(size=n) if draw(st.booleans()) else None,
        "qdot_prev": prev,
    }


def _stoppable(kw: dict[str, Any], lo_lim: np.ndarray, hi_lim: np.ndarray) -> np.ndarray:
    """(n,) booleans: some velocity of the rate box keeps ``q + dt v`` within
    ``[min(lo_lim, q), max(hi_lim, q)]`` (as float64 computes it)."""
    q, dt = kw["q"], kw["dt"]
    rlo, rhi, _ = rate_box(kw["limits"], dt, kw["qdot_prev"])
    top, bottom = np.maximum(hi_lim, q), np.minimum(lo_lim, q)
    return np.asarray((q + dt * rlo <= top) & (q + dt * rhi >= bottom))


def _past(kw: dict[str, Any], qdot: np.ndarray) -> np.ndarray:
    """(n,) distance of ``q + dt q̇`` past the hard limits (0 inside), a joint beyond its
    limit by the validation tolerance being allowed to stay."""
    q, lim = kw["q"], kw["limits"]
    nxt = q + kw["dt"] * qdot
    return np.asarray(
        np.maximum(np.maximum(nxt - np.maximum(lim.q_max, q), np.minimum(lim.q_min, q) - nxt), 0)
    )


@settings(max_examples=120, deadline=None)
@given(racing())
def test_the_flag_is_raised_exactly_when_a_crossing_was_unavoidable(kw: dict[str, Any]) -> None:
    """Every law, shield off: the flag's value is the largest distance past a hard limit over
    the joints that could not stop; a joint that could stop and crosses is the law's choice
    (never for sns and qp)."""
    lim = kw["limits"]
    stoppable = _stoppable(kw, lim.q_min, lim.q_max)
    for name in METHODS:
        res = make_law(name, shield=False)(**kw)
        past = _past(kw, res.qdot)
        forced = np.where(stoppable, 0.0, past)
        value = res.diagnostics.value(UNAVOIDABLE)
        if forced.max() > 0.0:
            assert value == forced.max(), (name, value, forced)
        else:
            assert value is None, (name, value, past)
        assert np.all(np.abs(res.qdot) <= lim.qdot_max), name


@settings(max_examples=120, deadline=None)
@given(racing())
def test_sns_and_qp_never_cross_when_stopping_is_possible(kw: dict[str, Any]) -> None:
    """Shield off: where some command within the rate limits keeps a joint within its safe
    limits (hard limits less the margin), ``sns`` and ``qp`` keep it there; where none keeps
    it within its hard limits, it crosses by the least the rate limits allow (their edge)."""
    lim, q, dt = kw["limits"], kw["q"], kw["dt"]
    safe_ok = _stoppable(kw, lim.safe_min, lim.safe_max)
    hard_ok = _stoppable(kw, lim.q_min, lim.q_max)
    rlo, rhi, _ = rate_box(lim, dt, kw["qdot_prev"])
    for name in ("sns", "qp"):
        res = make_law(name, shield=False)(**kw)
        nxt = q + dt * res.qdot
        top, bottom = np.maximum(lim.safe_max, q), np.minimum(lim.safe_min, q)
        inside = (nxt <= top) & (nxt >= bottom)
        assert np.all(inside | ~safe_ok), (name, nxt, top, bottom)
        past = _past(kw, res.qdot)
        assert np.all((past == 0.0) | ~hard_ok), name
        edge = np.where(nxt > top, rlo, rhi)
        assert np.all(hard_ok | (res.qdot == edge)), (name, res.qdot, edge)
        assert res.diagnostics.has(UNAVOIDABLE) == bool(np.any(~hard_ok)), name


@settings(max_examples=40, deadline=None)
@given(racing(), st.sampled_from(["sns", "qp"]))
def test_sns_and_qp_in_closed_loop_from_rest_never_cross(kw: dict[str, Any], name: str) -> None:
    """Starting at rest within the safe limits, the law's own previous command fed back:
    stopping always stays possible (the discrete braking bound), so 40 steps never cross the
    safe limits and never raise the flag, with the shield off."""
    lim, dt = kw["limits"], kw["dt"]
    q = np.clip(kw["q"], lim.safe_min, lim.safe_max)
    prev = np.zeros(lim.n)
    law = make_law(name, shield=False)
    for k in range(40):
        J1 = kw["J1"] * (1.0 + 0.3 * math.sin(0.2 * k))
        res = law(**{**kw, "J1": J1, "q": q, "qdot_prev": prev})
        nxt = q + dt * res.qdot
        assert np.all(nxt <= np.maximum(lim.safe_max, q)), (k, nxt)
        assert np.all(nxt >= np.minimum(lim.safe_min, q)), (k, nxt)
        assert not res.diagnostics.has(UNAVOIDABLE)
        q, prev = np.clip(nxt, lim.q_min, lim.q_max), res.qdot


# -- the compiled campaign loop ---------------------------------------------------------------


@pytest.mark.parametrize("dt", [10.0, 1.0, 0.04])
def test_the_campaign_loop_raises_the_same_flag(dt: float) -> None:
    """The loop kernel's step (every compiled law, shield off and on) on the reproducer:
    the law's command bit for bit and the same flag bits, the new flag included."""
    from redservo.campaign.fastloop import _flag_bits, _law_args
    from redservo.kernels.sensed import law_bits_sec
    from redservo.kernels.step import LAW_IDS
    from redservo.redundancy.packs import limits_pack

    kw = _case(dt)
    lim = kw["limits"]
    lp = limits_pack(lim)
    limits = (lp.rows, lp.has_v, lp.has_a, np.array(lim.q_min), np.array(lim.q_max))
    sim = (1.0, dt, 1e-3, True, np.ones(lim.n), False, False)
    z = np.zeros(lim.n)
    seen = 0
    for method in LAW_IDS:
        for shield in (False, True):
            law = make_law(method, shield=shield)
            args = _law_args(law, lim.n)
            ff = np.zeros(kw["e1"].shape[0])  # no feed-forward
            inputs = (kw["J1"], kw["e1"], ff, False, kw["q"], kw["qdot_prev"], z, False)
            qd, bits, _, abort = law_bits_sec(*inputs, args, limits, sim, z[:0])
            res = law(**kw)
            assert abort == 0
            assert np.array_equal(qd, res.qdot), (method, shield)
            assert bits == _flag_bits(res.diagnostics.events), (method, shield)
            seen += res.diagnostics.has(UNAVOIDABLE)
    assert seen == (len(LAW_IDS) if dt > 1.0 - 1e-12 else 0)


def test_the_campaign_loop_gives_sns_the_same_box_when_the_shield_box_is_empty() -> None:
    """The case of ``test_an_empty_position_box_does_not_send_the_joint_across`` through the
    loop kernel: the same command and flags as the law object."""
    from redservo.campaign.fastloop import _flag_bits, _law_args
    from redservo.kernels.sensed import law_bits_sec
    from redservo.redundancy.packs import limits_pack

    lim = JointLimits([0.0, -1.0], [1.0, 1.0], 0.1, margin=0.05, qdot_max=2.0, qddot_max=100.0)
    q, dt, prev = np.array([0.97, 0.0]), 0.3, np.zeros(2)
    J1, e1 = np.array([[1.0, 0.1]]), np.array([-1.0])
    lp = limits_pack(lim)
    limits = (lp.rows, lp.has_v, lp.has_a, np.array(lim.q_min), np.array(lim.q_max))
    sim = (1.0, dt, 1e-3, True, np.ones(2), False, False)
    law = make_law("sns", shield=False)
    args = _law_args(law, 2)
    qd, bits, _, _ = law_bits_sec(
        J1, e1, np.zeros(1), False, q, prev, np.zeros(2), False, args, limits, sim, np.zeros(0)
    )
    res = law(J1=J1, e1=e1, q=q, limits=lim, lam=1.0, dt=dt, qdot_prev=prev)
    assert np.array_equal(qd, res.qdot) and bits == _flag_bits(res.diagnostics.events)
    assert qd[0] == (0.95 - 0.97) / dt
