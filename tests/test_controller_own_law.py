"""A user's own law driven by :class:`redservo.Controller` directly gets the servo loop's
final guard (:mod:`redservo.control.law_output`): a NaN or a command far over the limits
was returned as it was, a list or a wrong length raised a bare AttributeError/ValueError,
and a None measurement or a string stamp went through."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo import Controller, ShapeError, make_law
from redservo.control import Measurement
from redservo.features import PointFeature
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics, LawResult
from redservo.redundancy.flags import Flag
from redservo.robots import Afma6
from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

Q = np.array([0.1, -0.2, 0.35, 0.4, 0.3, -0.2])
PTS = np.array([[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0.0]])
DT = 0.04


def _controller(law: Any, limits: JointLimits | None = None) -> tuple[Controller, Measurement]:
    robot = Afma6()
    scene = Scene(
        [
            PointSet(
                "sq", PTS, trajectory=Static(robot.fkine(Q) @ make_transform(t=(0.03, -0.02, 0.6)))
            )
        ]
    )
    task = VisualTask([TaskTerm(PointFeature(p), "sq") for p in PTS], np.zeros(8) + 0.05)
    s, inv_depth = task.measure(scene, robot.fkine(Q), 0.0)
    return Controller(robot, task, law, limits, lam=0.5, dt=DT), Measurement(s, inv_depth)


def _law(value: Any, shield: bool | None = None) -> Any:
    def own_law(**kw: Any) -> LawResult:
        n = kw["q"].shape[0]
        qdot = value(n) if callable(value) else value
        return LawResult(qdot, Diagnostics(method="mine"))  # type: ignore[arg-type]

    if shield is not None:
        own_law.shield = shield  # type: ignore[attr-defined]
    return own_law


def _flags(step: Any) -> set[Flag]:
    return {e.flag for e in step.diagnostics.events}


def test_a_nan_command_is_replaced_by_zeros_and_flagged() -> None:
    ctl, meas = _controller(_law(lambda n: np.full(n, np.nan)))
    step = ctl.step(Q, meas, 0.0, qdot_prev=np.zeros(6))
    assert np.array_equal(step.qdot, np.zeros(6))
    assert Flag.NON_FINITE_REPLACED in _flags(step)


def test_a_huge_command_is_scaled_into_the_limits_and_flagged() -> None:
    ctl, meas = _controller(_law(lambda n: np.full(n, 1e6)))
    qdot_max = ctl.limits.qdot_max
    assert qdot_max is not None
    step = ctl.step(Q, meas, 0.0, qdot_prev=None)
    assert np.all(np.abs(step.qdot) <= qdot_max * (1 + 1e-12))
    assert Flag.VELOCITY_SCALED in _flags(step)


def test_the_position_guard_keeps_a_joint_in_its_safe_range_unless_the_shield_is_off() -> None:
    limits = Afma6().limits()
    q = limits.safe_max - 1e-3  # every joint 1 mm / 1 mrad inside its safe range
    push = _law(lambda n: np.asarray(limits.qdot_max, dtype=float))
    ctl, meas = _controller(push)
    step = ctl.step(q, meas, 0.0, qdot_prev=None)
    assert np.all(q + DT * step.qdot <= limits.safe_max + 1e-12)
    assert Flag.SHIELD_ACTED in _flags(step)
    off, meas = _controller(_law(lambda n: np.asarray(limits.qdot_max, dtype=float), shield=False))
    assert np.any(q + DT * off.step(q, meas, 0.0, qdot_prev=None).qdot > limits.safe_max)


def test_a_shipped_law_is_not_guarded_twice() -> None:
    """The shipped laws check their own command (their safety layer): their step is theirs."""
    ctl, meas = _controller(make_law("classical"))
    by_hand = ctl.law(**ctl._law_kwargs(ctl.evaluate(meas, ctl.jacobian(Q)), Q, None, None, None))
    assert np.array_equal(ctl.step(Q, meas, 0.0, qdot_prev=None).qdot, by_hand.qdot)


@pytest.mark.parametrize(
    ("result", "match"),
    [
        ([0.0] * 6, "returned list"),
        (np.zeros(6), "returned ndarray"),
        (SimpleNamespace(qdot=np.zeros(5)), r"qdot = shape \(5,\)"),
        (SimpleNamespace(qdot=["a"] * 6), "qdot = "),
        (None, "returned NoneType"),
    ],
)
def test_a_law_returning_something_else_is_one_clear_error(result: Any, match: str) -> None:
    ctl, meas = _controller(lambda **kw: result)
    with pytest.raises(ShapeError, match=match) as info:
        ctl.step(Q, meas, 0.0, qdot_prev=None)
    assert info.value.argument == "law" and "a law returns an object with .qdot" in str(info.value)


def test_plain_diagnostics_are_kept_as_information() -> None:
    ctl, meas = _controller(lambda **kw: SimpleNamespace(qdot=np.zeros(6), diagnostics="ok"))
    step = ctl.step(Q, meas, 0.0, qdot_prev=None)
    assert step.diagnostics.method == "<lambda>" and "ok" in step.diagnostics.info[0]


@pytest.mark.parametrize("measurement", [None, "s", (1, 2)])
def test_a_measurement_without_features_is_one_clear_error(measurement: Any) -> None:
    ctl, _ = _controller(make_law("classical"))
    with pytest.raises(ShapeError, match=r"measurement must have \.s") as info:
        ctl.step(Q, measurement, 0.0, qdot_prev=None)
    assert info.value.argument == "measurement"


@pytest.mark.parametrize("stamp", ["1.0", True, float("nan"), None, np.bool_(True)])
def test_a_stamp_must_be_a_finite_number(stamp: Any) -> None:
    for law in (make_law("classical"), _law(lambda n: np.zeros(n))):
        ctl, meas = _controller(law)
        with pytest.raises(ShapeError, match="t must be a finite number of seconds"):
            ctl.step(Q, meas, stamp, qdot_prev=None)


def test_the_loop_clock_refuses_a_stamp_that_is_not_a_number() -> None:
    from redservo.hardware.clock import StampWatch

    for stamp in ("1.0", True):
        watch = StampWatch("joints", tolerance=0.01, timeout=0.2, t0=0.0)
        fault = watch.observe(stamp, arrival=1.0)
        assert not isinstance(fault, bool) and fault.kind == "non_finite"
    assert StampWatch("joints", tolerance=0.01, timeout=0.2, t0=0.0).observe(1.0, 1.0) is True


@settings(max_examples=200, deadline=None)
@given(
    raw=st.lists(
        st.floats(allow_nan=True, allow_infinity=True, width=64) | st.floats(-1e9, 1e9),
        min_size=6,
        max_size=6,
    ),
    prev=st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    frac=st.lists(st.floats(0.0, 1.0), min_size=6, max_size=6),
)
def test_a_guarded_own_law_never_breaks_a_limit(
    raw: list[float], prev: list[float], frac: list[float]
) -> None:
    limits = Afma6().limits().replace(qddot_max=2.0)
    q = limits.safe_min + np.asarray(frac) * (limits.safe_max - limits.safe_min)
    ctl, meas = _controller(_law(np.asarray(raw)), limits)
    qdot_prev = np.clip(np.asarray(prev), -limits.qdot_max, limits.qdot_max)  # type: ignore[arg-type]
    qdot = ctl.step(q, meas, 0.0, qdot_prev=qdot_prev).qdot
    assert np.all(np.isfinite(qdot))
    assert np.all(np.abs(qdot) <= limits.qdot_max * (1 + 1e-9))  # type: ignore[operator]
    assert np.all(q + DT * qdot <= limits.safe_max + 1e-9)
    assert np.all(q + DT * qdot >= limits.safe_min - 1e-9)
