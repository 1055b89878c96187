"""The object path's kernels write into arrays kept between calls (kernels.entry.Spares):
``task.evaluate`` and ``robot.kinematics`` hand their kernel two sets of output arrays instead
of receiving new ones (numba boxes each returned array), and a law call's kernel buffer is
one of two. A set is written again only when no result holds any of its arrays: every
result a caller keeps stays as it was, bit for bit the full path's, whatever the calls in
between (fuzzed: kept and dropped results, shapes and dtypes changed between calls, bad
input after the fast path was taken)."""

from __future__ import annotations

import copy
import pickle
import sys
from typing import Any

import numpy as np
import pytest

import redservo.features.compiled_points as cp_mod
from redservo import JointLimitError, ShapeError, make_law
from redservo.kernels import compiled
from redservo.kernels.entry import Spares
from redservo.robots import Afma6
from tests.test_public_path_speed import LAWS, _inputs, _same
from tests.test_task_kernel_path import NUMPY, _bits, _setup

needs_numba = pytest.mark.skipif(not compiled(), reason="the compiled paths need numba")


def test_spares_hand_out_a_set_no_one_holds() -> None:
    """The set not handed out last first, the other when the first is held (by the set
    itself or any of its arrays), a new set when both are; a dropped set is handed out
    again; a copy has arrays of its own."""
    sp = Spares(((3,), (2, 2)))
    first = id(sp.take())  # not held: the pool keeps it, so its id stays its own
    b = sp.take()
    assert id(b) != first and [x.shape for x in b] == [(3,), (2, 2)]
    held = b[1]  # one array of the set is enough to hold it
    del b
    c = sp.take()
    assert id(c) == first  # the other set is held
    same = sp.take()
    assert same is not c  # c (the set itself) is held: a new set
    kept = c[0]
    del c, same
    d = sp.take()
    assert d[0] is not kept and d[1] is not held
    del d
    for other in (copy.deepcopy(sp), pickle.loads(pickle.dumps(sp))):
        assert all(x is not y for s in sp.sets for t in other.sets for x in s for y in t)
    del kept, held
    handed = {id(sp.take()) for _ in range(6)}  # none held: the two sets in turn
    assert handed == {id(x) for x in sp.sets}


@needs_numba
@pytest.mark.parametrize("combine", [False, True], ids=["no-C", "C"])
def test_kept_task_states_stay_the_numpy_paths_whatever_the_calls_in_between(
    monkeypatch: pytest.MonkeyPatch, combine: bool
) -> None:
    """200 evaluations with random poses, a random choice of states (or single arrays of
    them) kept, Jacobians of 6 and 7 columns and in Fortran order mixed in: every kept state
    equals the numpy path's at the end, and the states made on the fast path are written
    into the task's spare arrays (on main each call had new arrays from the kernel)."""
    robot, scene, task, q0, rng = _setup(moving=True, base=True, combine=combine, seed=7)
    lim = robot.limits()
    kept: list[tuple[Any, Any, float, Any]] = []
    singles: list[tuple[Any, ...]] = []
    depths: list[tuple[Any, ...]] = []
    for i in range(200):
        q = np.clip(q0 + rng.normal(scale=0.05, size=6) * lim.range, lim.q_min, lim.q_max)
        bMc, J = robot.kinematics(q)
        if i % 17 == 5:
            J = np.hstack([J, rng.normal(size=(6, 1))])  # another n: other spares, same bits
        elif i % 23 == 7:
            J = np.asfortranarray(J)  # another layout: the dispatcher's path
        t = float(rng.uniform(0.0, 2.0))
        st = task.evaluate(scene, bMc, J, t)
        pick = rng.integers(4)
        if pick == 0:
            kept.append((bMc, J, t, st))
        elif pick == 1:
            singles.append((bMc, J, t, st[int(rng.integers(5))]))
        elif rng.integers(2):  # the inverse depths' tuple, or one of its (1,) views
            depths.append((bMc, J, t, st.inv_depth if rng.integers(2) else st.inv_depth[1]))
    hot = task.__dict__[cp_mod._HOT]
    st = task.evaluate(scene, *kept[-1][:3])
    assert any(st.L is s[4] for s in hot.spares.sets)
    want = [(x[:3], _bits(x[3])) for x in kept]
    got = [_bits(x[3]) for x in kept]
    monkeypatch.setattr(cp_mod, "_KT", NUMPY)
    for (args, fast), now in zip(want, got, strict=True):
        assert now == fast == _bits(task.evaluate(scene, *args))
    for bMc, J, t, arr in singles:
        ref = task.evaluate(scene, bMc, J, t)
        assert any(arr.tobytes() == np.ascontiguousarray(r).tobytes() for r in ref[:5])
    for bMc, J, t, d in depths:
        ref = task.evaluate(scene, bMc, J, t).inv_depth
        want = [x.tobytes() for x in ref] if type(d) is tuple else [ref[1].tobytes()]
        assert [x.tobytes() for x in (d if type(d) is tuple else (d,))] == want


@needs_numba
def test_a_bad_pose_after_the_fast_path_gets_the_same_error() -> None:
    robot, scene, task, q, _ = _setup(moving=False, base=False, combine=True, seed=4)
    bMc, J = robot.kinematics(q)
    kept = [task.evaluate(scene, bMc, J) for _ in range(3)]
    bad = bMc.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ShapeError, match="bMc must be finite"):
        task.evaluate(scene, bad, J)
    with pytest.raises(ShapeError, match="J must have shape"):
        task.evaluate(scene, bMc, J[:3])
    assert all(_bits(s) == _bits(kept[0]) for s in kept)


@needs_numba
def test_kept_kinematics_stay_a_fresh_robots() -> None:
    """Results kept or dropped at random over 300 calls (q inside and, once in a while,
    past a limit: the one error) equal a fresh robot's on the same q."""
    robot, ref = Afma6(), Afma6()
    lim = robot.limits()
    rng = np.random.default_rng(3)
    kept = []
    for i in range(300):
        q = lim.center + rng.uniform(-1, 1, 6) * lim.range / 2.2
        if i % 50 == 49:
            past = q.copy()
            past[2] = lim.q_max[2] + 1e-3
            with pytest.raises(JointLimitError, match=repr(robot.joint_names[2])):
                robot.kinematics(past)
        res = robot.kinematics(q)
        if rng.integers(3) == 0:
            kept.append((q, res if rng.integers(2) else res[1]))
    assert robot.__dict__["_kin_entry"].spares is not None
    for q, res in kept:
        want = ref.kinematics(q)
        if isinstance(res, tuple):
            assert [a.tobytes() for a in res] == [a.tobytes() for a in want]
        else:
            assert res.tobytes() == want[1].tobytes()


@needs_numba
@pytest.mark.parametrize("method", LAWS)
def test_kept_law_results_stay_a_fresh_laws(method: str) -> None:
    """Results kept (their command, their diagnostics unread, or both) while the law is
    called again on other inputs equal a fresh law's on the same inputs, diagnostics
    included; a NaN on the signature's path still gets the one error."""
    law = make_law(method)
    kept = []
    for seed in range(60):
        kw = _inputs(seed % 7, bool(seed % 2))  # m changes with the seed: new signatures too
        res = law(**kw)
        if seed % 3 == 0:
            kept.append((kw, res))
        elif seed % 3 == 1:
            kept.append((kw, res.qdot))
    bad = {**_inputs(0, False), "e1": np.full(_inputs(0, False)["e1"].shape, np.nan)}
    with pytest.raises(ShapeError, match="e1"):
        law(**bad)
    for kw, res in kept:
        want = make_law(method)(**kw)
        if isinstance(res, np.ndarray):
            assert res.tobytes() == want.qdot.tobytes()
        else:
            _same(res, want)


def test_the_benchmark_states_every_laws_path_against_visp() -> None:
    """``--laws``: a ``path X`` item per law, each with its ratio to ViSP and to the
    compiled step (issue 29's table has six laws)."""
    from tests.load_module import load_module

    bench = load_module("benchmarks/bench_object_path.py")
    laws = ("classical", "gpm", "wln")
    res = {f"path {m}": {"median_us": 14.0 + i} for i, m in enumerate(laws)}
    res.update({n: {"median_us": 10.0} for n in bench.VISP_TARGETS if n not in res})
    res.update(
        {"Controller.step": {"median_us": 12.0}, "Controller.step .qdot": {"median_us": 13.0}}
    )
    res["visp step"] = {"median_us": 7.0}
    lines = bench.ratio_lines(res)
    assert "path gpm / ViSP (7.00 µs, this run): 2.14x (target ≤ 2.5x: met)" in lines
    assert "path wln / ViSP (7.00 µs, this run): 2.29x (target ≤ 2.5x: met)" in lines
    assert "path wln / compiled measured step: 1.6x" in lines


@needs_numba
@pytest.mark.parametrize("method", ["iterative", "iterative-smooth", "wln", "classical"])
def test_the_laws_vector_read_from_its_buffer_is_the_two_stage_paths(method: str) -> None:
    """The law kernel writes its ``vec`` (the gains a and b, the levels' flags) into the
    call's buffer instead of returning a new array: on repeated calls with the signature
    seen (the buffers alternating) the diagnostics, ``a`` and ``b`` included, are those of
    compute() followed by the safety stage, near the limits where the levels fill ``vec``."""
    from tests.test_law_interface import _two_stage

    law = make_law(method)
    rng = np.random.default_rng(11)
    kept = []
    for i in range(40):
        kw = _inputs(int(rng.integers(100)), bool(i % 2))
        kw["J1"] = rng.normal(size=(3, 6))  # one signature: the repeated calls' path
        kw["e1"] = 5.0 * rng.normal(size=3)
        kept.append((kw, law(**kw)))
    masks = kept[-1][1].diagnostics._build[1][5]  # built when read: not read yet
    assert type(masks[2]) is int  # vec's length: diagnose reads vec from the call's buffer
    filled = 0
    for kw, res in kept:
        split = _two_stage(method)()(**kw)
        assert res.qdot.tobytes() == split.qdot.tobytes()
        assert repr(res.diagnostics) == repr(split.diagnostics)
        filled += res.diagnostics.b is not None and res.diagnostics.b.size > 0
    assert filled > 0 or method != "iterative"  # its levels fill b here


@needs_numba
def test_two_threads_calling_the_same_objects_never_share_a_set(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The kernels run without the GIL: two threads evaluating the same task and calling
    the same law at once each keep results equal to the full path's (a set found free by
    both would be written by both)."""
    import threading

    robot, scene, task, q0, rng = _setup(moving=True, base=False, combine=True, seed=9)
    lim = robot.limits()
    law = make_law("iterative-smooth")
    work = [
        np.clip(q0 + rng.normal(scale=0.05, size=6) * lim.range, lim.q_min, lim.q_max)
        for _ in range(400)
    ]
    law_kw = [_inputs(int(s), False) for s in rng.integers(1000, size=400)]
    for kw in law_kw:  # one signature
        kw["J1"], kw["e1"] = rng.normal(size=(3, 6)), rng.normal(size=3)
    got: list[list[Any]] = [[], []]

    def run(k: int) -> None:
        sys.setswitchinterval(1e-6)
        for i in range(k, 400, 2):
            bMc, J = robot.kinematics(work[i])
            got[k].append((i, bMc, J, task.evaluate(scene, bMc, J, 0.01 * i), law(**law_kw[i])))

    interval = sys.getswitchinterval()
    try:
        threads = [threading.Thread(target=run, args=(k,)) for k in (0, 1)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
    finally:
        sys.setswitchinterval(interval)
    ref = Afma6()
    fresh = make_law("iterative-smooth")
    monkeypatch.setattr(cp_mod, "_KT", NUMPY)
    for i, bMc, J, st, res in got[0] + got[1]:
        assert [a.tobytes() for a in (bMc, J)] == [a.tobytes() for a in ref.kinematics(work[i])]
        assert _bits(st) == _bits(task.evaluate(scene, bMc, J, 0.01 * i))
        assert res.qdot.tobytes() == fresh(**law_kw[i]).qdot.tobytes()
