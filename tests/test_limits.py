"""Tests of JointLimits (CM01 eqs. 3-6 and 17; docs/formulas.md §5.1, §7.2, §7.5)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo import ConfigurationError, JointLimitError, JointLimits, ShapeError

LIM = JointLimits([-1.0, 0.0, -0.5], [1.0, 2.0, 3.5], rho=0.1)
q_in = st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3).map(
    lambda u: LIM.q_min + np.asarray(u) * LIM.range
)


def test_thresholds_eq3_per_axis() -> None:
    """q̃_min = q̄_min + ρ Δq̄_i, q̃_max = q̄_max - ρ Δq̄_i, with Δq̄ per axis (docs/formulas.md §5.1)."""
    np.testing.assert_allclose(LIM.q_tilde_min, [-0.8, 0.2, -0.1])
    np.testing.assert_allclose(LIM.q_tilde_max, [0.8, 1.8, 3.1])
    # With the [-1, 1] normalization the thresholds sit at ±(1 - 2ρ) = ±0.8 (see docs/decisions.md).
    np.testing.assert_allclose(LIM.normalized(LIM.q_tilde_min), -0.8)
    np.testing.assert_allclose(LIM.normalized(LIM.q_tilde_max), 0.8)
    np.testing.assert_allclose(LIM.normalized(LIM.q_min), -1.0)
    np.testing.assert_allclose(LIM.normalized(LIM.q_max), 1.0)


def test_cost_and_gradient_eqs_4_to_6() -> None:
    q = np.array([0.9, 1.0, -0.3])  # axis 0 above its threshold, 1 inside, 2 below
    s = np.array([0.9 - 0.8, 0.0, -0.3 + 0.1])
    assert LIM.cost(q) == pytest.approx(0.5 * np.sum(s**2 / LIM.range))
    np.testing.assert_allclose(LIM.gradient(q), s / LIM.range)
    assert LIM.cost(LIM.center) == 0.0 and not LIM.gradient(LIM.center).any()


@settings(max_examples=200, deadline=None)
@given(q_in)
def test_gradient_is_the_derivative_of_the_cost(q: np.ndarray) -> None:
    h = 1e-7
    fd = np.array(
        [
            (LIM.cost(q + h * np.eye(3)[i]) - LIM.cost(q - h * np.eye(3)[i])) / (2 * h)
            for i in range(3)
        ]
    )
    np.testing.assert_allclose(LIM.gradient(q), fd, atol=1e-6)


def _gamma_eq17(qh: float, lo: float, hi: float, tlo: float, thi: float) -> float:
    """CM01 eq. 17 as printed, with the third case corrected (docs/formulas.md §7.5), clamped beyond q̄."""
    if qh <= tlo:
        return min(1.0, (qh - tlo) / (lo - tlo))
    if qh >= thi:
        return min(1.0, (qh - thi) / (hi - thi))
    return 0.0


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-0.2, 1.2), min_size=3, max_size=3))
def test_gamma_matches_eq_17(u: list[float]) -> None:
    qh = LIM.q_min + np.asarray(u) * LIM.range  # also beyond the real limits
    want = [
        _gamma_eq17(qh[i], LIM.q_min[i], LIM.q_max[i], LIM.q_tilde_min[i], LIM.q_tilde_max[i])
        for i in range(3)
    ]
    np.testing.assert_allclose(LIM.gamma(qh), want, atol=1e-12)


@settings(max_examples=300, deadline=None)
@given(q_in, st.lists(st.floats(-0.2, 0.2), min_size=3, max_size=3))
def test_critical_rule(q: np.ndarray, step: list[float]) -> None:
    """Critical iff q̂ is in the band (or beyond) and nearer its limit than q (docs/formulas.md §7.2)."""
    qh = q + np.asarray(step) * LIM.range
    got = LIM.critical(q, qh)
    for i in range(3):
        upper = qh[i] >= LIM.q_tilde_max[i] and LIM.q_max[i] - qh[i] < LIM.q_max[i] - q[i]
        lower = qh[i] <= LIM.q_tilde_min[i] and qh[i] - LIM.q_min[i] < q[i] - LIM.q_min[i]
        assert got[i] == (upper or lower)


def test_margin_and_distance() -> None:
    q = np.array([0.9, 0.1, 3.0])
    np.testing.assert_allclose(LIM.distance(q), [0.1, 0.1, 0.5])
    np.testing.assert_allclose(LIM.margin(q), [0.05, 0.05, 0.125])
    assert LIM.margin(LIM.center) == pytest.approx(0.5)
    assert LIM.contains(q) and not LIM.contains(q + 5.0)
    np.testing.assert_array_equal(LIM.in_band(q), [True, True, False])


def test_bad_limits_and_bad_q() -> None:
    with pytest.raises(JointLimitError, match="strictly greater"):
        JointLimits([0.0, 1.0], [1.0, 1.0])
    with pytest.raises(ConfigurationError, match="rho"):
        JointLimits([0.0], [1.0], rho=0.5)
    with pytest.raises(ShapeError, match="q_max"):
        JointLimits([0.0, 0.0], [1.0])
    with pytest.raises(JointLimitError, match=r"q\[1\] = 2\.5 is outside"):
        LIM.check([0.0, 2.5, 0.0])
    with pytest.raises(ShapeError, match="shape"):
        LIM.check([0.0, 1.0])
    with pytest.raises(ShapeError, match="finite"):
        LIM.check([0.0, np.nan, 0.0])


@pytest.mark.parametrize(
    ("kwargs", "argument", "error"),
    [
        ({"q_min": ["-1", "0"]}, "q_min", ShapeError),
        ({"q_max": ["1", "1"]}, "q_max", ShapeError),
        ({"qdot_max": "2.0"}, "qdot_max", ConfigurationError),
        ({"qddot_max": ["1", "2"]}, "qddot_max", ConfigurationError),
        ({"margin_abs": "0.01"}, "margin_abs", ConfigurationError),
        ({"qdot_max": [True, True]}, "qdot_max", ConfigurationError),
    ],
)
def test_limits_take_numbers_only(kwargs: dict[str, object], argument: str, error: type) -> None:
    """Strings were parsed by numpy and accepted (issue 17 item 6)."""
    args: dict[str, object] = {"q_min": [-1.0, 0.0], "q_max": [1.0, 1.0], **kwargs}
    with pytest.raises(error) as info:
        JointLimits(**args)  # type: ignore[arg-type]
    assert info.value.argument == argument and argument in str(info.value)
    with pytest.raises(ShapeError) as shape:
        LIM.check(["0", "1", "2"])
    assert shape.value.argument == "q"


def test_margin_abs_may_be_zero_on_some_joints() -> None:
    lim = JointLimits([-1.0, -1.0], [1.0, 1.0], margin_abs=[0.0, 0.1])
    np.testing.assert_array_equal(lim.safe_max, [1.0, 0.9])
    with pytest.raises(
        ConfigurationError, match=r"margin_abs\[0\] = -0\.1 must be a finite number >= 0"
    ):
        JointLimits([-1.0, -1.0], [1.0, 1.0], margin_abs=[-0.1, 0.1])
