"""The law call's fast path (issue 29 item 3): diagnostics built when first read, equal to
the eager ones, and no Python check of the values once the signature is the kernel's."""

from __future__ import annotations

import copy
import pickle
from typing import Any

import numpy as np
import pytest

import redservo.redundancy.base as base
from redservo import Diagnostics, JointLimitError, JointLimits, ShapeError, make_law
from redservo.redundancy.base import LazyDiagnostics
from redservo.redundancy.inputs import validate_inputs
from redservo.redundancy.kernel_call import diagnose, kernel_call


def _eager(law: Any, kw: dict[str, Any]) -> tuple[Any, Diagnostics] | None:
    """``(q̇, diagnostics)`` of the law kernel call on ``kw``, the diagnostics built now."""
    done = kernel_call(law, validate_inputs(de1_dt=None, secondary=None, **kw))
    return None if done is None else (done[0], diagnose(*done[1]))


LAWS = ("classical", "gpm", "gpm-auto", "iterative", "iterative-smooth", "directional")


def _inputs(seed: int) -> dict[str, Any]:
    """Inputs near the limits, with rate limits: events from the law and its safety layer."""
    rng = np.random.default_rng(seed)
    n, m = 6, int(rng.integers(1, 5))
    lim = JointLimits(
        -np.ones(n), np.ones(n), rho=0.1, qdot_max=np.full(n, 0.3), qddot_max=np.full(n, 2.0)
    )
    J1 = rng.normal(size=(m, n))
    if seed % 3 == 0:
        J1[-1] = J1[0]  # rank loss
    return {
        "J1": J1,
        "e1": 5.0 * rng.normal(size=m),
        "q": rng.uniform(-0.99, 0.99, n),
        "limits": lim,
        "lam": 0.8,
        "dt": 0.04,
        "qdot_prev": rng.uniform(-0.3, 0.3, n) if seed % 2 else None,
    }


@pytest.mark.parametrize("method", LAWS)
@pytest.mark.parametrize("seed", range(6))
def test_lazy_diagnostics_equal_the_eager_ones(method: str, seed: int) -> None:
    kw = _inputs(seed)
    law = make_law(method)
    res = law(**kw)
    assert isinstance(res.diagnostics, LazyDiagnostics)
    eager = _eager(law, kw)
    assert eager is not None and type(eager[1]) is Diagnostics
    assert res.qdot.tobytes() == eager[0].tobytes()
    assert repr(res.diagnostics) == repr(eager[1])
    assert res.diagnostics.notes == eager[1].notes
    assert res.diagnostics.flags == eager[1].flags
    if method == "classical":  # no array fields: the dataclass equality works both ways
        assert res.diagnostics == eager[1] and eager[1] == res.diagnostics


def test_lazy_diagnostics_keep_the_state_of_the_call() -> None:
    """Changing ``q`` or ``qdot`` in place, or the law's options, after the call does not
    change the diagnostics read later."""
    kw = _inputs(1)
    kw["q"][0] = 0.999  # the shield acts
    law = make_law("gpm")
    eager = _eager(law, kw)
    assert eager is not None and eager[1].events
    res = law(**kw)
    kw["q"][:] = 0.0
    res.qdot[:] = 123.0
    law.set_safety(robust=False)
    law.alpha = 7.0
    assert repr(res.diagnostics) == repr(eager[1])


def test_lazy_diagnostics_print_pickle_and_replace_as_diagnostics() -> None:
    res = make_law("classical")(**_inputs(2))
    d = res.diagnostics
    back = pickle.loads(pickle.dumps(d))
    assert type(back) is Diagnostics and back == d
    assert type(copy.copy(d)) is Diagnostics
    assert repr(d).startswith("Diagnostics(method='classical'")
    import dataclasses

    more = dataclasses.replace(d, info=("x",))
    assert more.info == ("x",) and more.task_rank == d.task_rank


def test_a_second_call_with_the_same_signature_runs_no_python_validation(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    kw = _inputs(3)
    law = make_law("iterative-smooth")
    first = law(**kw)

    def refuse(**_: Any) -> Any:
        raise AssertionError("validated in Python")

    monkeypatch.setattr(base, "validate_inputs", refuse)
    again = law(**kw)
    assert again.qdot.tobytes() == first.qdot.tobytes()


@pytest.mark.parametrize(
    ("name", "value", "error"),
    [
        ("q", np.array([0.0, 0.0, np.nan, 0.0, 0.0, 0.0]), ShapeError),
        ("q", np.array([0.0, 0.0, 1.5, 0.0, 0.0, 0.0]), JointLimitError),
        ("e1", np.array([np.inf]), ShapeError),
        ("qdot_prev", np.full(6, np.nan), ShapeError),
    ],
)
def test_the_fast_path_still_names_a_bad_value(name: str, value: Any, error: type) -> None:
    """The kernel's check sends a bad value to the full checks, which name it."""
    kw = _inputs(4)
    if name == "e1":
        kw["J1"], kw["e1"] = kw["J1"][:1].copy(), kw["e1"][:1].copy()
    law = make_law("classical")
    law(**kw)  # the signature is known
    kw[name] = value
    with pytest.raises(error) as info:
        law(**kw)
    assert info.value.argument == name


def test_the_compiled_controller_step_gives_lazy_diagnostics_equal_to_the_object_paths() -> None:
    from redservo import Controller
    from redservo.bench.cases import bench_cases
    from redservo.control import Measurement

    case = next(c for c in bench_cases(scaling=()) if c.name == "afma6-4points")
    bMc, J = case.robot.kinematics(case.q)
    st = case.task.evaluate(case.scene, bMc, J, 0.0)
    meas = Measurement(st.s, tuple(st.inv_depth))
    steps = {}
    for engine in ("auto", "python"):
        law = make_law("iterative-smooth")
        ctl = Controller(
            case.robot, case.task, law, case.limits, lam=case.lam, dt=case.dt, engine=engine
        )
        steps[engine] = ctl.step(case.q.copy(), meas, 0.0, qdot_prev=None)
    fast, ref = steps["auto"], steps["python"]
    assert isinstance(fast.diagnostics, LazyDiagnostics)
    assert fast.qdot.tobytes() == ref.qdot.tobytes()
    assert repr(fast.diagnostics) == repr(ref.diagnostics)


def test_numpy_float_gains_take_the_fast_path_with_the_same_command(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    kw = _inputs(5)
    law = make_law("gpm")
    ref = law(**kw)

    def refuse(**_: Any) -> Any:
        raise AssertionError("validated in Python")

    monkeypatch.setattr(base, "validate_inputs", refuse)
    res = law(**{**kw, "lam": np.float64(kw["lam"]), "dt": np.float64(kw["dt"])})
    assert res.qdot.tobytes() == ref.qdot.tobytes()
    assert repr(res.diagnostics) == repr(ref.diagnostics)
