"""The law interface, checked for every registered method, plus classical.py and linalg.py.

Iterates over :data:`redservo.METHODS`, so laws added later are covered automatically.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import redservo
from redservo import (
    METHOD_DESCRIPTIONS,
    METHODS,
    ConfigurationError,
    JointLimitError,
    JointLimits,
    ShapeError,
    UnknownNameError,
    make_law,
)
from redservo.redundancy.base import registered_methods
from redservo.redundancy.linalg import pinv, task_svd
from tests.laws import paper_law

N = 6
LIMITS = JointLimits(-np.ones(N), np.ones(N), rho=0.1)


def good_inputs(m: int = 2, seed: int = 0) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    return {
        "J1": rng.normal(size=(m, N)),
        "e1": rng.normal(size=m),
        "q": np.array([0.95, -0.9, 0.0, 0.3, -0.5, 0.85]),
        "limits": LIMITS,
        "lam": 0.5,
        "dt": 0.04,
        "de1_dt": 0.1 * rng.normal(size=m),
        "secondary": 0.2 * rng.normal(size=N),
    }


def call(method: str, **overrides: Any) -> redservo.LawResult:
    kw = good_inputs()
    kw.update(overrides)
    return paper_law(method)(**kw)


# -- registry ------------------------------------------------------------------------------------


def test_registry_is_consistent() -> None:
    reg = registered_methods()
    assert set(METHODS) == set(reg) and len(METHODS) == len(set(METHODS))
    for name in METHODS:
        assert reg[name].name == name
        assert METHOD_DESCRIPTIONS[name] and reg[name].description == METHOD_DESCRIPTIONS[name]
    assert METHODS[0] == "classical"


def test_unknown_method_lists_the_known_ones() -> None:
    with pytest.raises(UnknownNameError) as info:
        make_law("no-such-method")
    message = str(info.value)
    assert "no-such-method" in message
    for name in METHODS:
        assert name in message


@pytest.mark.parametrize("method", METHODS)
def test_unknown_option(method: str) -> None:
    with pytest.raises(ConfigurationError, match="no_such_option"):
        make_law(method, no_such_option=1.0)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("rcond", [0.0, -1e-3, 1.0, float("nan")])
def test_bad_rcond(method: str, rcond: float) -> None:
    with pytest.raises(ConfigurationError):
        make_law(method, rcond=rcond)


# -- bad inputs ----------------------------------------------------------------------------------

BAD_SHAPES = {
    "J1 1-D": {"J1": np.ones(N)},
    "J1 3-D": {"J1": np.ones((1, 2, N))},
    "J1 wrong n": {"J1": np.ones((2, N + 1))},
    "J1 no rows": {"J1": np.ones((0, N)), "e1": np.ones(0), "de1_dt": None},
    "e1 wrong m": {"e1": np.ones(3)},
    "e1 2-D": {"e1": np.ones((2, 1))},
    "q wrong n": {"q": np.zeros(N - 1)},
    "q 2-D": {"q": np.zeros((N, 1))},
    "de1_dt wrong m": {"de1_dt": np.ones(3)},
    "secondary wrong n": {"secondary": np.ones(N + 1)},
    "limits wrong n": {"limits": JointLimits(-np.ones(N + 1), np.ones(N + 1))},
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", BAD_SHAPES)
def test_wrong_shape_raises_shape_error(method: str, case: str) -> None:
    with pytest.raises(ShapeError):
        call(method, **BAD_SHAPES[case])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["J1", "e1", "q", "de1_dt", "secondary"])
@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_input_raises_shape_error(method: str, name: str, bad: float) -> None:
    value = np.array(good_inputs()[name], dtype=float)
    value.flat[1] = bad
    with pytest.raises(ShapeError):
        call(method, **{name: value})


@pytest.mark.parametrize("method", METHODS)
def test_q_outside_limits(method: str) -> None:
    for q in (np.array([1.01, 0, 0, 0, 0, 0]), np.array([0, 0, 0, 0, 0, -1.5])):
        with pytest.raises(JointLimitError):
            call(method, q=q)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["lam", "dt"])
@pytest.mark.parametrize("value", [0.0, -0.1, float("nan"), float("inf")])
def test_non_positive_gain_or_period(method: str, name: str, value: float) -> None:
    with pytest.raises(ConfigurationError):
        call(method, **{name: value})


# -- outputs -------------------------------------------------------------------------------------


def _cases() -> dict[str, dict[str, Any]]:
    rng = np.random.default_rng(11)
    row = rng.normal(size=N)
    return {
        "generic 2x6": {},
        "no feed-forward or secondary": {"de1_dt": None, "secondary": None},
        "m = n": {"J1": rng.normal(size=(N, N)), "e1": rng.normal(size=N), "de1_dt": None},
        "m > n": {"J1": rng.normal(size=(N + 2, N)), "e1": rng.normal(size=N + 2), "de1_dt": None},
        "rank-deficient": {
            "J1": np.vstack([row, -row, rng.normal(size=N)]),
            "e1": rng.normal(size=3),
            "de1_dt": None,
        },
        "zero J1": {"J1": np.zeros((2, N))},
        "zero error": {"e1": np.zeros(2), "de1_dt": None, "secondary": None},
        "at limits and thresholds": {"q": np.array([1.0, -1.0, 0.8, -0.8, 0.0, 1.0])},
        "large error": {"e1": np.array([1e3, -1e3])},
    }


CASES = _cases()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", CASES)
def test_output_finite_shape_and_name(method: str, case: str) -> None:
    kw = good_inputs()
    kw.update(CASES[case])
    r = paper_law(method)(**kw)
    assert isinstance(r, redservo.LawResult)
    assert r.qdot.shape == (N,)
    assert np.isfinite(r.qdot).all()
    d = r.diagnostics
    assert d.method == method
    assert isinstance(d.notes, tuple)
    assert 0 <= d.task_rank <= min(kw["J1"].shape)
    assert d.rank_deficient == (d.task_rank < kw["J1"].shape[0])


@pytest.mark.parametrize("method", METHODS)
@settings(max_examples=15, deadline=None)
@given(
    m=st.integers(1, N + 1),
    seed=st.integers(0, 2**32 - 1),
    scale=st.sampled_from([0.0, 1e-6, 1.0, 1e3]),
)
def test_random_inputs_never_raise(method: str, m: int, seed: int, scale: float) -> None:
    rng = np.random.default_rng(seed)
    kw = good_inputs(m=m, seed=seed)
    kw["J1"] = kw["J1"] * scale
    kw["q"] = rng.uniform(LIMITS.q_min, LIMITS.q_max)
    kw["q"][rng.integers(N)] = LIMITS.q_max[0]
    r = paper_law(method)(**kw)
    assert r.qdot.shape == (N,) and np.isfinite(r.qdot).all()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", ["generic 2x6", "at limits and thresholds", "rank-deficient"])
def test_laws_are_pure(method: str, case: str) -> None:
    kw = good_inputs()
    kw.update(CASES[case])
    copies = {k: np.array(v, copy=True) for k, v in kw.items() if isinstance(v, np.ndarray)}
    law = paper_law(method)
    if law.stateful:  # a stateful law must be reproducible after reset()
        law.reset()
    first = law(**kw)
    if law.stateful:
        law.reset()
    second = law(**kw)
    np.testing.assert_array_equal(first.qdot, second.qdot)
    assert first.diagnostics.critical == second.diagnostics.critical
    for k, v in copies.items():  # inputs are not modified
        np.testing.assert_array_equal(kw[k], v, err_msg=k)
    # a fresh instance gives the same command too
    np.testing.assert_array_equal(paper_law(method)(**kw).qdot, first.qdot)


@pytest.mark.parametrize("method", METHODS)
def test_accepts_lists(method: str) -> None:
    kw = good_inputs()
    a = paper_law(method)(**kw).qdot
    as_lists = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in kw.items()}
    np.testing.assert_array_equal(paper_law(method)(**as_lists).qdot, a)


# -- classical -----------------------------------------------------------------------------------


@settings(max_examples=40, deadline=None)
@given(m=st.integers(1, N), seed=st.integers(0, 2**32 - 1), sec=st.booleans(), ff=st.booleans())
def test_classical_formula(m: int, seed: int, sec: bool, ff: bool) -> None:
    kw = good_inputs(m=m, seed=seed)
    if not sec:
        kw["secondary"] = None
    if not ff:
        kw["de1_dt"] = None
    J, e, lam = kw["J1"], kw["e1"], kw["lam"]
    Jp = np.linalg.pinv(J)
    want = -lam * Jp @ e  # CM01 eq. 2 with e = J1⁺ e1
    if ff:
        want = want - Jp @ kw["de1_dt"]
    if sec:
        want = want + (np.eye(N) - Jp @ J) @ kw["secondary"]
    r = paper_law("classical")(**kw)
    np.testing.assert_allclose(r.qdot, want, atol=1e-10 * (1 + np.abs(want).max()))
    assert r.diagnostics.critical == () and r.diagnostics.task_rank == m
    task_rate = -lam * e - (kw["de1_dt"] if ff else 0.0)
    np.testing.assert_allclose(J @ r.qdot, task_rate, atol=1e-9 * (1 + np.abs(r.qdot).max()))


# -- linalg --------------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(m=st.integers(1, 9), n=st.integers(1, 9), seed=st.integers(0, 2**32 - 1))
def test_pinv_and_null_basis_full_rank(m: int, n: int, seed: int) -> None:
    A = np.random.default_rng(seed).normal(size=(m, n))
    np.testing.assert_allclose(pinv(A), np.linalg.pinv(A), atol=1e-9)
    svd = task_svd(A)
    r = min(m, n)
    assert svd.rank == r
    E = svd.null
    assert E.shape == (n, n - r)
    np.testing.assert_allclose(E.T @ E, np.eye(n - r), atol=1e-12)  # orthonormal
    np.testing.assert_allclose(A @ E, 0.0, atol=1e-12 * (1 + np.abs(A).max()))
    np.testing.assert_allclose(svd.pinv, np.linalg.pinv(A), atol=1e-9)
    np.testing.assert_allclose(svd.null_projector(), np.eye(n) - svd.pinv @ A, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(m=st.integers(2, 7), n=st.integers(2, 7), seed=st.integers(0, 2**32 - 1))
def test_pinv_rank_deficient_is_moore_penrose(m: int, n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    r = int(rng.integers(1, min(m, n)))
    A = rng.normal(size=(m, r)) @ rng.normal(size=(r, n))  # rank r < min(m, n)
    svd = task_svd(A)
    assert svd.rank == r
    X = svd.pinv
    atol = 1e-9 * (1 + np.abs(A).max()) * (1 + np.abs(X).max()) ** 2
    np.testing.assert_allclose(A @ X @ A, A, atol=atol)
    np.testing.assert_allclose(X @ A @ X, X, atol=atol)
    np.testing.assert_allclose(A @ X, (A @ X).T, atol=atol)
    np.testing.assert_allclose(X @ A, (X @ A).T, atol=atol)
    E = svd.null
    assert E.shape == (n, n - r)
    np.testing.assert_allclose(E.T @ E, np.eye(n - r), atol=1e-12)
    np.testing.assert_allclose(A @ E, 0.0, atol=1e-10 * (1 + np.abs(A).max()))


def test_linalg_edge_cases() -> None:
    Z = task_svd(np.zeros((2, 4)))
    assert Z.rank == 0
    np.testing.assert_array_equal(Z.pinv, np.zeros((4, 2)))
    np.testing.assert_allclose(Z.null @ Z.null.T, np.eye(4), atol=1e-12)
    assert pinv(np.zeros((0, 3))).shape == (3, 0)
    assert pinv(np.zeros((3, 0))).shape == (0, 3)
    tiny = np.diag([1.0, 1e-12])  # below the default relative cut-off: rank 1
    assert task_svd(tiny).rank == 1
    np.testing.assert_allclose(pinv(tiny), np.diag([1.0, 0.0]))


# -- issue 17 item 6: names in every input error ----------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", ["J1", "e1", "q", "de1_dt", "secondary", "qdot_prev"])
@pytest.mark.parametrize("kind", ["strings", "booleans", "objects"])
def test_non_numeric_inputs_are_refused_by_name(method: str, name: str, kind: str) -> None:
    """``q = ["0.1", "0.2", ...]`` was parsed by numpy and accepted; every array input now
    takes numbers only and the error names the argument."""
    good = good_inputs()
    value = np.asarray(good.get(name, np.zeros(N)))
    with_none = value.astype(object)
    with_none.flat[-1] = None
    bad: Any = {
        "strings": value.astype(str).tolist(),
        "booleans": (value > 0).tolist(),
        "objects": with_none.tolist(),
    }[kind]
    with pytest.raises(ShapeError) as info:
        call(method, **{name: bad})
    assert info.value.argument == name and str(info.value).startswith(name)


@pytest.mark.parametrize("method", METHODS)
def test_integers_and_mixed_lists_are_numbers(method: str) -> None:
    kw = good_inputs()
    q = [0, 0, 0, 0, 0, 1]  # ints, one at the limit
    a = paper_law(method)(**{**kw, "q": np.array(q, dtype=float)}).qdot
    np.testing.assert_array_equal(paper_law(method)(**{**kw, "q": q}).qdot, a)
    mixed = [np.float32(0.5), 0, np.int64(0), 0.0, -0.5, 1]
    paper_law(method)(**{**kw, "q": mixed})


@pytest.mark.parametrize("name", ["J1", "e1", "de1_dt", "secondary", "qdot_prev"])
def test_an_overflowing_input_is_named(name: str) -> None:
    """Entries near 1e308 whose own sum overflows: the error names the argument (it named
    none: "inputs are too large (their sum overflows)")."""
    value = np.full(np.shape(good_inputs().get(name, np.zeros(N))), 1e308)
    with np.errstate(over="ignore"), pytest.raises(ShapeError) as info:
        call("classical", **{name: value})
    assert info.value.argument == name and str(info.value).startswith(name)
    assert "overflow" in str(info.value)


def test_inputs_whose_sums_only_overflow_together_are_valid() -> None:
    """Each array finite with a finite sum: nothing to report (the sum over all of them is
    only the hot path's shortcut)."""
    J1 = np.zeros((2, N))
    J1[0, 0] = 1.5e308
    with np.errstate(over="ignore"):
        res = call("classical", J1=J1, e1=np.array([1.5e308, 0.0]), de1_dt=None)
    assert np.isfinite(res.qdot).all()


@pytest.mark.parametrize("scale", [1.5e7, 3e7, 1e9, 1e12, 1e14])
@pytest.mark.parametrize("upper", [False, True])
def test_a_q_just_past_a_large_limit_names_the_joint(scale: float, upper: bool) -> None:
    """|q| ~ 1.5e7: ``q_min - 1e-9`` rounds to one float step below ``q_min``, so the check
    that found the joint disagreed with the laws' test and the error had ``joint=None``."""
    lo = np.array([-1.0, scale, -1.0])
    lim = JointLimits(lo, lo + np.array([2.0, 1.0, 2.0]))
    q = np.zeros(3)
    limit = lim.q_max[1] if upper else lim.q_min[1]
    q[1] = limit
    while abs(q[1] - limit) <= 1e-9:  # the first float beyond the tolerance
        q[1] = np.nextafter(q[1], np.inf if upper else -np.inf)
    kw = {"J1": np.eye(2, 3), "e1": np.zeros(2), "limits": lim, "lam": 0.5, "dt": 0.01}
    with pytest.raises(JointLimitError) as info:
        make_law("classical")(**kw, q=q)
    exc = info.value
    assert (exc.argument, exc.joint, exc.value) == ("q", 1, q[1])
    q[1] = np.nextafter(q[1], -np.inf if upper else np.inf)  # within the tolerance: valid
    make_law("classical")(**kw, q=q)
    lim.check(q)


# -- flags: one rule (kernels/events.py), one message table (redundancy/messages.py) -----------


def test_the_kernels_number_every_flag_and_the_table_words_every_source() -> None:
    from redservo.kernels import flagbits
    from redservo.redundancy.flags import FLAGS
    from redservo.redundancy.messages import MESSAGES

    assert [getattr(flagbits, f.name) for f in FLAGS] == list(range(flagbits.N_FLAGS))
    assert set(MESSAGES) == set(FLAGS)
    for flag, table in MESSAGES.items():
        bits = list(table)
        assert bits and all(b > 0 and b & (b - 1) == 0 for b in bits), flag  # one bit each
        assert len(set(bits)) == len(bits), flag


def test_a_flag_raised_for_two_reasons_is_one_event_with_both_messages() -> None:
    """ACCELERATION_EXCEEDED released on a joint and exceeded on another: one event, the
    first reason's value (NaN), both messages."""
    from redservo.kernels import flagbits as fb
    from redservo.redundancy.flags import FLAGS, Flag
    from redservo.redundancy.messages import events

    vals, src = np.zeros(fb.N_FLAGS), np.zeros(fb.N_FLAGS, dtype=np.int64)
    j = FLAGS.index(Flag.ACCELERATION_EXCEEDED)
    vals[j], src[j] = np.nan, fb.ACC_RELEASED | fb.ACC_KEPT_POSITION
    (event,) = events(1 << j, vals, src, worst=0.25)
    assert event.flag is Flag.ACCELERATION_EXCEEDED and np.isnan(event.value)
    assert "released on some joints" in event.message and "exceeded by 0.25" in event.message


def test_gpm_auto_damped_twice_reports_both_filters() -> None:
    """The task inverse and eq. 9 both filtered (a fuzz case): one DAMPED event whose value
    is the task filter's bound and whose message names both."""
    from redservo.redundancy.flags import Flag

    rng = np.random.default_rng(0)
    for _ in range(2000):
        n = 6
        J1 = rng.normal(size=(3, n))
        J1[2] = J1[1] + 1e-6 * rng.normal(size=n)
        lim = JointLimits(-np.ones(n), np.ones(n), 0.2)
        q = rng.uniform(-0.99, 0.99, n)
        res = make_law("gpm-auto")(J1=J1, e1=rng.normal(size=3), q=q, limits=lim, lam=1, dt=0.1)
        d = res.diagnostics
        damped = [e for e in d.events if e.flag is Flag.DAMPED]
        assert len(damped) <= 1
        if damped and "eq. 9 filtered" in damped[0].message and "J1 ill" in damped[0].message:
            assert damped[0].value == 1e3 and "; " in damped[0].message
            return
    pytest.skip("no case with both filters met")  # pragma: no cover


# -- options: declared once (Law.OPTIONS) --------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
def test_options_declared_once_give_signature_repr_and_validation(method: str) -> None:
    import inspect

    from redservo.redundancy import law_class
    from redservo.redundancy.options import check_option

    cls = law_class(method)
    params = inspect.signature(cls.__init__).parameters
    declared = {o.name: o for o in cls.OPTIONS}
    assert [p for p in params if p != "self"] == list(declared)
    law = make_law(method)
    for name, option in declared.items():
        assert params[name].default is option.default
        assert f"    {name}: {option.doc}" in (cls.__doc__ or "")  # generated Options section
        assert f"{name}=" in repr(law)
        value = getattr(law, name)
        assert value is None if option.default is None else value == option.default
        assert (option.doc and check_option(option, option.default) is not None) or option.none
    for name, option in declared.items():
        bad = "x" if option.kind not in ("choice", "str") else 3
        with pytest.raises(ConfigurationError, match=f"^{name} ") as info:
            make_law(method, **{name: bad})
        assert info.value.argument == name and option.allowed() in str(info.value)


@pytest.mark.parametrize("method", [m for m in METHODS if m not in ("qp", "qp-goal", "predictive")])
def test_each_declared_option_is_packed_into_its_own_slot(method: str) -> None:
    """Changing one option changes its slot of the compiled step's pack and no other option's
    slot, and no two options or extras of a law share a slot."""
    from redservo.redundancy import law_class
    from redservo.redundancy.kio import law_options

    cls = law_class(method)
    base = make_law(method)
    slots = [o.slot for o in cls.OPTIONS if o.slot is not None]
    slots += [s for s, _ in base.packed_extras()]
    assert len(slots) == len(set(slots)), method
    ref = law_options(base, 4)
    extras = {s for s, _ in base.packed_extras()}  # may follow an option (has v_max, ...)
    other = {"float": None, "int": 2, "bool": False, "per-joint": 0.25}
    for option in cls.OPTIONS:
        if option.slot is None:
            continue
        if option.kind == "choice":
            value: Any = option.choices[-1]
        elif option.kind == "float":
            lo = 0.0 if option.low is None else option.low
            hi = lo + 1.0 if option.high is None else option.high
            value = lo + 0.37 * (hi - lo)
        else:
            value = other[option.kind]
        kw = {option.name: value}
        if method == "large-projection" and option.name == "e0":
            kw["e1"] = 1.0
        got = law_options(make_law(method, **kw), 4)
        changed = {
            (k, j)
            for k, a, b in zip("fiv", ref[1:], got[1:], strict=True)
            for j in range(a.shape[0])
            if not np.array_equal(a[j], b[j])
        }
        allowed = {option.slot, *extras, *(o.slot for o in cls.OPTIONS if o.name in kw)}
        assert option.slot in changed and changed <= allowed, (option.name, changed)


def _outcome(fn: Any) -> Any:
    try:
        x = fn()
    except redservo.RedservoError as exc:
        return (type(exc).__name__, str(exc))
    return tuple(
        v.tobytes() if isinstance(v, np.ndarray) else v for v in x if not isinstance(v, JointLimits)
    )


@pytest.mark.parametrize("seed", range(40))
def test_the_kernel_check_of_the_inputs_agrees_with_the_full_checks(seed: int) -> None:
    """validate_inputs takes contiguous float64 arrays through one kernel; lists take the full
    checks: both accept the same inputs with the same values and refuse with the same error
    (NaN, inf, entries near 1e308, ``q`` at a limit's tolerance of 1e-9 and past it)."""
    from redservo.redundancy.inputs import validate_inputs

    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(1, 7)), int(rng.integers(2, 8))
    lim = JointLimits(-np.ones(n), np.ones(n), rho=0.1)
    kw: dict[str, Any] = {
        "J1": rng.normal(size=(m, n)),
        "e1": rng.normal(size=m),
        "q": rng.uniform(-0.9, 0.9, n),
        "de1_dt": rng.normal(size=m) if seed % 2 else None,
        "secondary": rng.normal(size=n) if seed % 3 else None,
        "qdot_prev": rng.normal(size=n) if seed % 4 else None,
    }
    name = ("J1", "e1", "q", "de1_dt", "secondary", "qdot_prev")[seed % 6]
    if kw[name] is not None:
        bad = kw[name].reshape(-1)
        bad[int(rng.integers(bad.size))] = (np.nan, np.inf, -1.7e308, 1e301, 0.5)[seed % 5]
    if seed % 7 == 0:
        kw["q"][0] = (1.0 + 1e-9, 1.0 + 2e-9, -1.0 - 1e-9, -1.0 - 1.1e-9)[seed % 4]
    args = {"limits": lim, "lam": 0.5, "dt": 0.04}
    fast = _outcome(lambda: validate_inputs(**kw, **args))
    lists = {k: None if v is None else v.tolist() for k, v in kw.items()}
    full = _outcome(lambda: validate_inputs(**lists, **args))
    assert fast == full


def _two_stage(method: str) -> Any:
    """The law ``method`` through compute() then the safety stage (a subclass with its own
    compute takes that path)."""
    base = redservo.redundancy.base.law_class(method)

    def compute(self: Any, x: Any) -> Any:
        return base.compute(self, x)

    return type(f"TwoStage{base.__name__}", (base,), {"compute": compute})


def _fuzzed_call(seed: int) -> dict[str, Any]:
    """A law call's keywords drawn from ``seed``: 1-8 task rows, 2-8 joints, velocity
    limits and (odd seeds) acceleration limits, a margin, a rank loss (seeds divisible by
    4), errors over six decades, ``q`` up to the limits, a secondary (odd seeds) and a
    previous command (seeds not divisible by 3)."""
    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(1, 9)), int(rng.integers(2, 9))
    lim = JointLimits(
        -np.ones(n),
        np.ones(n),
        rho=0.1,
        qdot_max=rng.uniform(0.01, 1.0, n),
        qddot_max=rng.uniform(0.01, 5.0, n) if seed % 2 else None,
        margin=0.01 if seed % 3 else 0.0,
    )
    J1 = rng.normal(size=(m, n))
    if seed % 4 == 0:
        J1[-1] = J1[0]  # rank loss
    return {
        "J1": J1,
        "e1": rng.normal(size=m) * 10.0 ** rng.uniform(-3, 3),
        "q": rng.uniform(-1.0, 1.0, n) * (1.0 if seed % 5 else 0.999),
        "limits": lim,
        "lam": float(rng.uniform(0.1, 5.0)),
        "dt": float(10.0 ** rng.uniform(-3, 0.5)),
        "secondary": rng.normal(size=n) if seed % 2 else None,
        "qdot_prev": rng.uniform(-1, 1, n) * lim.qdot_max if seed % 3 else None,
    }


_STEP_KERNEL_LAWS = (
    "classical",
    "gpm",
    "gpm-auto",
    "iterative",
    "iterative-smooth",
    "directional",
    "large-projection",
    "wln",
)


@pytest.mark.parametrize("method", _STEP_KERNEL_LAWS)
@pytest.mark.parametrize("shield", [True, False])
@pytest.mark.parametrize("seed", range(12))
def test_a_law_call_through_the_step_kernel_equals_law_then_safety(
    method: str, seed: int, shield: bool
) -> None:
    """``Law.__call__`` through the step kernel (law, flag rules and safety stage in one
    kernel, ``redundancy/kernel_call.py``) returns the command bit for bit and the same
    diagnostics as compute() followed by apply_safety, for every law it covers."""
    kw = _fuzzed_call(seed)
    fused = make_law(method, shield=shield)(**kw)
    split = _two_stage(method)().set_safety(shield=shield)(**kw)
    assert fused.qdot.tobytes() == split.qdot.tobytes()
    assert repr(fused.diagnostics) == repr(split.diagnostics)  # some hold arrays
    assert fused.diagnostics.notes == split.diagnostics.notes


@pytest.mark.parametrize("method", ["predictive", "qp-goal"])
def test_set_safety_reaches_the_inner_law(method: str) -> None:
    """A law that calls another for its commands (predictive's fallback, qp-goal's qp) sets
    the same safety options on it, and a bad value changes neither."""
    from redservo.redundancy.base import make_law

    law = make_law(method)
    (inner,) = law._inner_laws()
    law.set_safety(shield=False, robust=False, scaling="secondary-first")
    assert (inner.shield, inner.robust, inner.scaling) == (False, False, "secondary-first")
    with pytest.raises(ConfigurationError, match="shield"):
        law.set_safety(shield="yes")  # type: ignore[arg-type]
    assert (law.shield, inner.shield) == (False, False)


def test_a_bad_safety_option_changes_nothing() -> None:
    """set_safety checks every value before it sets any: a bad ``robust`` leaves ``shield``
    as it was (it used to be set before ``robust`` was checked)."""
    from redservo.redundancy.base import make_law

    law = make_law("classical")
    with pytest.raises(ConfigurationError, match="robust"):
        law.set_safety(shield=False, robust="no")  # type: ignore[arg-type]
    assert law.shield is True


def _qp_compiled(law: Any, kw: dict[str, Any]) -> Any:
    """``(q̇, diagnostics)`` of the ``qp`` law's compiled Controller step
    (``kernels/qp_control.qp_core``, its outputs laid out as the Controller's buffer and read
    by the law's ``diagnose``) on the law call's keywords ``kw``; None when the kernel hands
    the step to the object path."""
    from redservo.binding.control_law import control_pack
    from redservo.kernels import control, qp_control
    from redservo.redundancy.kernel_call import LAW_PARTS, diagnose
    from redservo.redundancy.packs import limits_pack

    def given(v: Any) -> Any:
        return np.zeros(0) if v is None else np.ascontiguousarray(v, dtype=float)

    J1, e1, q, lim = kw["J1"], kw["e1"], kw["q"], kw["limits"]
    (m, n), dt = J1.shape, kw["dt"]
    lp = limits_pack(lim)
    inputs = (given(kw.get("de1_dt")), given(kw["secondary"]), given(kw["qdot_prev"]))
    status, out, lev, sev = qp_control.qp_core(
        q, J1, e1, control_pack(law, n), (lp.rows, lp.has_v, lp.has_a), (kw["lam"], dt), inputs
    )
    if status != 1:
        return None
    qdot, iout, fout, axes, axf, vec, sout = out
    events = (lev[1], lev[2].astype(float), sev[1], sev[2].astype(float))
    buf = np.concatenate([qdot, iout.astype(float), fout, sout, axes, axf, *events])
    layout = control.control_layout(n, 0, 0)
    parts = tuple(slice(*layout[k]) for k in LAW_PARTS)
    safety = (q.copy(), qdot.copy(), dt, lim) if sev[0] else None
    args = (type(law), dict(law.__dict__), m, buf, parts, (lev[0], sev[0], vec), safety)
    return qdot, diagnose(*args)


@pytest.mark.parametrize("shield", [True, False])
def test_qp_compiled_step_equals_its_law_call(shield: bool) -> None:
    """The ``qp`` law's compiled Controller step (``kernels/qp_control.py``, its diagnostics
    by the law's ``diagnose``) gives the command bit for bit and the diagnostics of the law
    object's call (``compute``, then the safety layer), on fuzzed calls that reach every
    branch: the unconstrained optimum inside the bounds, the compiled solver with and
    without its polish, bounds in conflict with ``v_max``, rank loss, a secondary command
    and a feed-forward."""
    seen: set[str] = set()
    conflicts = 0
    for seed in range(60):
        kw = _fuzzed_call(seed)
        rng = np.random.default_rng(1000 + seed)
        n = kw["q"].shape[0]
        if seed % 5 == 1:
            kw["de1_dt"] = rng.normal(size=kw["e1"].shape[0])
        opts: dict[str, Any] = {"margin": 0.05 * (seed % 3), "k_p": (1.0, 0.5)[seed % 2]}
        if seed % 4 == 3:
            opts["v_max"] = rng.uniform(0.001, 0.5, n)
        law = make_law("qp", **opts).set_safety(shield=shield)
        compiled = _qp_compiled(law, kw)
        assert compiled is not None, seed
        ref = law(**kw)
        assert compiled[0].tobytes() == ref.qdot.tobytes(), seed
        assert repr(compiled[1]) == repr(ref.diagnostics), seed  # events may hold NaN
        assert compiled[1].notes == ref.diagnostics.notes, seed
        seen.add(ref.diagnostics.info[0])
        conflicts += any(e.flag.value == "bounds-conflict" for e in ref.diagnostics.events)
    assert seen == {
        "solver: none (unconstrained optimum within the bounds)",
        "solver: active-set",
        "solver: active-set + active-set polish",
    }
    assert conflicts > 0
