"""The kernel layer: compiled and plain-Python runs of one source agree; the campaign loop's
iteration (the step kernel on the ideal sensor) gives the public objects' command; ``import redservo`` stays light."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo import METHODS, JointLimits, make_law
from redservo.bench.cases import bench_cases
from redservo.bench.sensed import sensed_iteration
from redservo.redundancy.kio import law_options
from redservo.redundancy.packs import limits_pack

numba = pytest.importorskip("numba", reason="the compiled path needs numba (redservo[fast])")

from redservo.kernels import bls as kbls  # noqa: E402
from redservo.kernels import (  # noqa: E402
    directional,
    events,
    features,
    iterative,
    kinematics,
    laws,
    linalg,
    moment_interaction,
    moments,
    projection,
    qp,
    safety,
    sns,
    step,
)

SETTINGS = settings(max_examples=25, deadline=None)
seeds = st.integers(0, 2**32 - 1)


def assert_same(a: Any, b: Any, tol: float = 1e-10) -> None:
    """Outputs equal to ``tol`` relative to ``1 + |a|`` (tuples, arrays, numbers)."""
    if isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            assert_same(x, y, tol)
        return
    x = np.asarray(a)
    y = np.asarray(b)
    assert x.shape == y.shape
    if x.dtype == bool or np.issubdtype(x.dtype, np.integer):
        assert np.array_equal(x, y)
        return
    assert np.allclose(x, y, rtol=tol, atol=tol, equal_nan=True), (x, y)


def both(kernel: Any, *args: Any) -> None:
    """Run ``kernel`` compiled and through ``.py_func`` on the same inputs and compare."""
    with np.errstate(all="ignore"):
        assert_same(kernel(*args), kernel.py_func(*args))


def problem(seed: int) -> dict[str, Any]:
    """A random law input: J1 (m, n) with rank loss or bad conditioning now and then."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 9))
    m = int(rng.integers(1, n + 2))
    J1 = rng.normal(size=(m, n))
    if seed % 5 == 0 and m > 1:
        J1[-1] = 2.0 * J1[0]
    if seed % 7 == 0:
        J1[:, 0] *= 1e-5
    lo, hi = -rng.uniform(0.5, 3.0, n), rng.uniform(0.5, 3.0, n)
    rates = {"qdot_max": rng.uniform(0.1, 2.0, n), "qddot_max": rng.uniform(0.5, 5.0, n)}
    limits = JointLimits(lo, hi, 0.1, margin=0.02, **(rates if seed % 2 else {}))
    frac = np.where(rng.uniform(size=n) < 0.5, rng.uniform(0.0, 0.12, n), rng.uniform(0, 1, n))
    e = rng.normal(size=m) * 10.0 ** rng.uniform(-2, 1)
    return {
        "J1": J1,
        "e": e,
        "q": lo + frac * (hi - lo),
        "lp": limits_pack(limits),
        "sec": rng.normal(size=n) * 0.1,
        "has_sec": bool(seed % 3 == 0),
        "prev": rng.normal(size=n) * 0.2,
    }


@SETTINGS
@given(seed=seeds)
def test_law_kernels_compiled_and_plain_agree(seed: int) -> None:
    p = problem(seed)
    J1, e, q, lp, sec, hs = p["J1"], p["e"], p["q"], p["lp"].rows, p["sec"], p["has_sec"]
    n = q.shape[0]
    both(linalg.task_svd, J1, 1e-8, 1e-3)
    both(laws.classical, J1, e, 0.7, sec, hs, 1e-8, 1e-3)
    both(laws.gpm, J1, e, q, lp, 0.7, sec, hs, 2.0, 1e-8, 0.0)
    both(laws.gpm_auto, J1, e, q, lp, 0.7, 0.04, sec, hs, np.inf, False, 1e-8, 1e-3, True)
    both(
        iterative.iterative, J1, e, q, lp, 0.7, 0.04, sec, hs, True, 2.0, -1, 1e-8, 1e-3, 1e-8, 1e-2
    )
    both(
        directional.directional,
        J1,
        e,
        e,
        e,
        False,
        q,
        lp,
        0.7,
        0.04,
        sec,
        hs,
        1.0,
        True,
        1.0,
        1e-8,
        1e-3,
    )
    both(directional.wln, J1, e, q, lp, 0.7, sec, hs, False, sec, False, 1e-8, 1e-3, 1e-9)
    both(
        projection.large_projection,
        J1,
        e,
        e,
        q,
        lp,
        0.7,
        sec,
        hs,
        0.1,
        0.7,
        0,
        0.1,
        0.3,
        0.7,
        1e-8,
        1e-3,
        1e-2,
    )
    has_v, has_a = p["lp"].has_v, p["lp"].has_a
    v = np.full(n, 0.5)
    args = (J1, e, q, lp, has_v, has_a, 0.7, 0.04, p["prev"], True, sec, hs)
    both(sns.sns, *args, v, True, v, False, 1.0, 1e-8)
    both(
        qp.qp_prepare,
        *args[:3],
        lp,
        has_v,
        has_a,
        0.04,
        p["prev"],
        True,
        sec,
        hs,
        0.7,
        1.0,
        0.0,
        v,
        True,
        1e-8,
    )
    raw = sec * 30.0
    both(safety.apply_safety, raw, q, lp, has_v, has_a, 0.04, p["prev"], True, True, raw, False)
    both(safety.apply_safety, raw, q, lp, has_v, has_a, 0.04, p["prev"], True, True, sec, True)
    both(kbls.bls_reduce, J1, e, -v, v, sec, 1e-6)


@SETTINGS
@given(seed=seeds)
def test_event_kernels_compiled_and_plain_agree(seed: int) -> None:
    """The flag rules (kernels/events.py) on the outputs of every law kernel, and the step's
    mask: the same masks, values and sources compiled and as plain Python."""
    p = problem(seed)
    J1, e, q, lp, sec, hs = p["J1"], p["e"], p["q"], p["lp"].rows, p["sec"], p["has_sec"]
    m, n = J1.shape
    rb = 1e-3 if seed % 2 else 0.0
    out = laws.classical(J1, e, 0.7, sec, hs, 1e-8, rb)
    both(events.classical_events, m, n, out[1], rb)
    both(events.gpm_events, m, n, out[1], rb)
    cap = 0.5 if seed % 3 else np.inf
    out = laws.gpm_auto(J1, e, q, lp, 0.7, 0.04, sec, hs, cap, False, 1e-8, rb, True)
    both(events.gpm_auto_events, m, n, out[1], out[4], rb, cap)
    it = iterative.iterative(J1, e, q, lp, 0.7, 0.04, sec, hs, True, 2.0, -1, 1e-8, rb, 1e-8, 1e-2)
    both(events.iterative_events, m, n, it[1], it[2], it[5], rb, 1e-2)
    both(events.unmet_levels, it[1], it[5])
    out = directional.wln(J1, e, q, lp, 0.7, sec, hs, False, sec, False, 1e-8, rb, 1e-9)
    both(events.wln_events, m, n, out[1], rb)
    both(events.directional_events, m, n, out[1], rb)
    both(events.sns_events, m, m - seed % 2, 1.0 - 0.1 * (seed % 3), bool(seed % 5))
    args = (0.1, 0.7, 0, 0.1, 0.3, 0.7, 1e-8, rb, 1e-2)
    out = projection.large_projection(J1, e, e, q, lp, 0.7, sec, hs, *args)
    both(events.large_projection_events, m, n, out[1], out[3], rb, 1e-2)
    both(events.qp_events, m, m - 1, q > 0.0, bool(seed % 2), 1e-3 * (seed % 3))
    raw = sec * 30.0
    has_v, has_a = p["lp"].has_v, p["lp"].has_a
    safe = safety.apply_safety(raw, q, lp, has_v, has_a, 0.04, p["prev"], True, True, raw, False)
    both(events.safety_events, *safe[1:10])
    both(
        events.safety_with_events, raw, q, lp, has_v, has_a, 0.04, p["prev"], True, True, raw, False
    )
    zero = it[2].copy()
    zero[3] = 0.0  # a constraint level with σ_min = 0: flagged with an infinite amplification
    both(events.iterative_events, m, n, it[1], zero, it[5], rb, 1e-2)
    assert events.iterative_events(m, n, it[1], zero, it[5], rb, 1e-2)[1][2] == np.inf
    law = make_law("iterative-smooth", robust=bool(seed % 2))
    o = law_options(law, n)
    none = np.zeros(0)
    inputs = (none, sec if hs else none, p["prev"], none)
    law_pack, lim = (o.law_id, o.fopt, o.iopt, o.vopt), (lp, has_v, has_a)
    res = step.law_step(law_pack, lim, (0.7, 0.04), J1, e, q, inputs)
    both(step.step_events, o.law_id, o.fopt, m, *res[1:])


@SETTINGS
@given(seed=seeds)
def test_feature_and_kinematics_kernels_compiled_and_plain_agree(seed: int) -> None:
    rng = np.random.default_rng(seed)
    T = np.eye(4)
    T[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    if np.linalg.det(T[:3, :3]) < 0:
        T[:3, 0] *= -1.0
    T[:3, 3] = (rng.normal() * 0.1, rng.normal() * 0.1, 0.8 + rng.uniform(0.0, 0.5))
    pts = rng.normal(size=(4, 3)) * 0.05
    pts[:, 2] = 0.0
    both(features.points_measure, T, pts)
    both(features.line_interaction, rng.normal(), rng.normal(), rng.normal(size=3))
    both(features.project_line, T[:3, 3], rng.normal(size=3))
    both(features.cylinder_lines, 0.05, rng.normal(size=3), T[:3, 3])
    both(features.sphere_ellipse, 0.05, *T[:3, 3])
    s = np.array([0.1, -0.05, 0.02])
    both(features.sphere_interaction, s, rng.normal(size=3))
    both(features.ellipse_moment_interaction, rng.normal(size=5) * 0.1, rng.normal(size=3))
    for kind in (0, 1, 2):
        both(moments.moment_measure, pts, T, 0.01, 0.5, kind)
        _, plane, xg, yg, mu, code, _ = moments.moment_measure(pts, T, 0.01, 0.5, kind)
        if code == 0:
            both(
                moment_interaction.moment_features_interaction,
                4,
                xg,
                yg,
                mu,
                plane,
                0.01,
                0.5,
                kind,
            )
    q = rng.uniform(-0.5, 0.5, 6)
    both(kinematics.afma6_kinematics, q, T, np.eye(6), 0.009091, -0.06924)
    par = np.vstack([np.zeros(6), np.zeros(6), rng.uniform(0, 0.3, 6), rng.uniform(0, 0.3, 6)])
    alpha = rng.choice([-np.pi / 2, 0.0, np.pi / 2], 6)
    par = np.ascontiguousarray(
        np.vstack([par, np.cos(alpha), np.sin(alpha), np.ones(6), np.zeros(6)])
    )
    both(kinematics.dh_kinematics, q, par, np.eye(4), np.eye(4), bool(seed % 2), T, np.eye(6))


def test_rotation_invariants_complex_steps_are_exact() -> None:
    """The complex step needs exact integer powers: numba's complex ``**`` is not (a bug
    this test caught); compiled and plain agree on complex input too."""
    x = np.array([0.01, 0.002, 0.008, 0.0003, -0.0002, 0.0001, 0.0004], dtype=complex)
    x[5] += 1e-30j
    for kind in (0, 1, 2):
        a, b = moments.rotation_invariants(x, kind), moments.rotation_invariants.py_func(x, kind)
        assert np.allclose(a.imag, b.imag, rtol=1e-10, atol=0.0)


@pytest.mark.parametrize(
    "case", ["afma6-4points", "afma6-gaze", "afma6-moments", "panda-6d-bounds"]
)
def test_the_campaigns_iteration_gives_the_public_command(case: str) -> None:
    """The campaign loop's kernels at one q (sense, then the step kernel's law part) give
    ``task.evaluate`` then ``law(...)`` for every law of the step kernel."""
    c = next(x for x in bench_cases(scaling=()) if x.name == case)
    bMc, J = c.robot.kinematics(c.q)
    state = c.task.evaluate(c.scene, bMc, J, 0.0)
    prev = np.linspace(-0.05, 0.05, c.robot.n)
    for method in METHODS:
        if method not in step.LAW_IDS:  # qp, predictive: a solver between kernels
            continue
        law = make_law(method, scaling="secondary-first" if method == "gpm" else "uniform")
        ref = law(
            J1=state.J1, e1=state.e1, q=c.q, limits=c.limits, lam=c.lam, dt=c.dt, qdot_prev=prev
        )
        run = sensed_iteration(c.robot, c.scene, c.task, law, limits=c.limits, lam=c.lam, dt=c.dt)
        out = run(c.q, prev)
        assert np.allclose(out, ref.qdot, rtol=1e-9, atol=1e-12), method
        assert law_options(law, c.robot.n).law_id == step.LAW_IDS[method]
        e1, J1 = run.task(c.q)
        assert np.allclose(e1, state.e1, atol=1e-12) and np.allclose(J1, state.J1, atol=1e-10)


@pytest.mark.parametrize("shield", [True, False])
@pytest.mark.parametrize("case", ["afma6-4points", "panda-6d-free", "panda-6d-bounds"])
def test_the_campaigns_qp_iteration_gives_the_public_command(case: str, shield: bool) -> None:
    """``qp`` with its compiled solver, also with the shield off: the campaign's iteration
    passes the law's ``shield`` on."""
    c = next(x for x in bench_cases(scaling=()) if x.name == case)
    bMc, J = c.robot.kinematics(c.q)
    state = c.task.evaluate(c.scene, bMc, J, 0.0)
    law = make_law("qp", v_max=1.5, shield=shield)
    prev = np.linspace(-0.05, 0.05, c.robot.n)
    ref = law(J1=state.J1, e1=state.e1, q=c.q, limits=c.limits, lam=c.lam, dt=c.dt, qdot_prev=prev)
    run = sensed_iteration(c.robot, c.scene, c.task, law, limits=c.limits, lam=c.lam, dt=c.dt)
    assert np.allclose(run(c.q, prev), ref.qdot, rtol=1e-9, atol=1e-12)


def test_plain_python_path_runs_every_law(tmp_path: Any) -> None:
    """With numba disabled the same kernels run as plain Python and give the same commands."""
    code = (
        "import json, numpy as np\n"
        "from redservo import METHODS, JointLimits, make_law\n"
        "from redservo.kernels._jit import COMPILED\n"
        "rng = np.random.default_rng(3); J1 = rng.normal(size=(3, 6)); e1 = rng.normal(size=3)\n"
        "lim = JointLimits(-np.ones(6), np.ones(6), qdot_max=1.0, qddot_max=5.0)\n"
        "q = np.array([0.95, -0.9, 0.1, 0.0, 0.5, -0.3])\n"
        "out = {m: make_law(m)(J1=J1, e1=e1, q=q, limits=lim, lam=1.0, dt=0.04).qdot.tolist()"
        " for m in METHODS}\n"
        "print(json.dumps([COMPILED, out]))\n"
    )
    env = {**os.environ, "REDSERVO_NO_NUMBA": "1"}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    compiled_flag, plain = json.loads(done.stdout.strip().splitlines()[-1])
    assert compiled_flag is False
    rng = np.random.default_rng(3)
    J1, e1 = rng.normal(size=(3, 6)), rng.normal(size=3)
    lim = JointLimits(-np.ones(6), np.ones(6), qdot_max=1.0, qddot_max=5.0)
    q = np.array([0.95, -0.9, 0.1, 0.0, 0.5, -0.3])
    for m in METHODS:
        here = make_law(m)(J1=J1, e1=e1, q=q, limits=lim, lam=1.0, dt=0.04).qdot
        assert np.allclose(here, plain[m], rtol=1e-9, atol=1e-12), m


def test_import_redservo_loads_no_heavy_module() -> None:
    code = (
        "import sys, redservo\n"
        "heavy = ('numba', 'scipy.optimize', 'scipy.linalg', 'matplotlib', 'cv2', 'pinocchio')\n"
        "print([m for m in heavy if m in sys.modules])"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"
