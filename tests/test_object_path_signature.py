"""The object path's repeated calls (issue 29 item 3): ``law(...)``, ``robot.kinematics(q)`` and
``task.evaluate(...)`` called again with the set-up of an earlier call look only at the
metadata of the new inputs (types, shapes, layouts) and call their kernel at its entry point;
the numbers stay those of the full path bit for bit, anything that changed takes the full
path again, and a bad value still gets its one error naming the argument."""

from __future__ import annotations

import copy
import pickle
from typing import Any

import numpy as np
import pytest

import redservo.features.compiled_points as cp_mod
import redservo.redundancy.kernel_call as kc
import redservo.robots.afma6 as afma6_mod
from redservo import JointLimitError, ShapeError, make_law
from redservo.kernels import compiled
from redservo.robots import Afma6
from tests.test_public_path_speed import LAWS, _inputs, _same, _same_diag
from tests.test_task_kernel_path import NUMPY, _bits, _setup

needs_numba = pytest.mark.skipif(not compiled(), reason="entry points are numba's")


def _refuse(*_: Any, **__: Any) -> Any:
    raise AssertionError("the full path was taken")


def _fresh(kw: dict[str, Any]) -> dict[str, Any]:
    """The same inputs in new arrays (the same limits object)."""
    return {k: v.copy() if isinstance(v, np.ndarray) else v for k, v in kw.items()}


@needs_numba
@pytest.mark.parametrize("method", LAWS)
@pytest.mark.parametrize("prev", [False, True])
def test_a_repeated_law_call_checks_only_the_inputs_metadata(
    method: str, prev: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Once the signature is known, a call neither re-checks each array nor goes through
    ``fast_call`` (on main every call did both), with a fresh law's numbers to the bit."""
    kw = _inputs(11, prev)
    law = make_law(method)
    law(**kw)
    law(**kw)
    monkeypatch.setattr(kc, "fast_call", _refuse)
    monkeypatch.setattr(kc, "_array", _refuse)
    monkeypatch.setattr(kc, "_bound", _refuse)
    got = [law(**_fresh(kw)), law(**{**_fresh(kw), "qdot_prev": None})]
    monkeypatch.undo()
    _same(got[0], make_law(method)(**kw))
    _same(got[1], make_law(method)(**{**kw, "qdot_prev": None}))


@needs_numba
def test_diagnostics_kept_from_a_repeated_call_say_the_options_of_that_call() -> None:
    """The law's options are read for the diagnostics once per signature: an option set
    afterwards changes the next call's diagnostics, never those of a result already made."""
    kw = _inputs(12, True)
    law = make_law("iterative-smooth")
    law(**kw)
    kept = law(**_fresh(kw))  # the signature's path, diagnostics not read yet
    law.set_safety(robust=False)
    later = law(**_fresh(kw))
    law(**_fresh(kw))
    last = law(**_fresh(kw))
    _same(kept, make_law("iterative-smooth")(**kw))
    _same(later, make_law("iterative-smooth", robust=False)(**kw))
    _same_diag(last.diagnostics, later.diagnostics)


@needs_numba
@pytest.mark.parametrize(
    ("name", "bad", "error"),
    [
        ("e1", lambda e: np.full_like(e, np.nan), ShapeError),
        ("J1", lambda J: np.where(J > 0, np.inf, J), ShapeError),
        ("q", lambda q: q + 5.0, JointLimitError),
        ("qdot_prev", lambda v: np.full_like(v, np.nan), ShapeError),
    ],
)
def test_a_bad_value_on_the_signatures_path_gets_the_one_error(
    name: str, bad: Any, error: type[Exception]
) -> None:
    kw = _inputs(13, True)
    law = make_law("classical")
    law(**kw)
    law(**kw)
    kw[name] = bad(kw[name])
    with pytest.raises(error) as info:
        law(**kw)
    assert getattr(info.value, "argument", None) == name


@needs_numba
def test_a_law_call_with_a_strided_array_takes_the_full_path_with_the_same_numbers() -> None:
    kw = _inputs(14, True)
    law = make_law("gpm")
    law(**kw)
    law(**kw)
    strided = _fresh(kw)
    strided["J1"] = np.repeat(kw["J1"], 2, axis=1)[:, ::2]
    assert not strided["J1"].flags.c_contiguous
    _same(law(**strided), make_law("gpm")(**kw))


class _Refusing:
    """A kernel handle whose dispatcher must not be called."""

    COMPILED = True
    afma6_checked = staticmethod(_refuse)


@needs_numba
def test_afma6_kinematics_calls_its_kernels_entry_once_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The second call finds the entry, the next ones call it (on main every call went
    through numba's dispatcher), with the same numbers as a fresh robot's."""
    robot, ref = Afma6(), Afma6()
    q = robot.limits().center + 0.1
    robot.kinematics(q)
    robot.kinematics(q)
    monkeypatch.setattr(afma6_mod, "_KJ", _Refusing)
    got = robot.kinematics(q.copy())
    monkeypatch.undo()
    want = ref.kinematics(q)
    assert all(a.tobytes() == b.tobytes() for a, b in zip(got, want, strict=True))


@needs_numba
def test_afma6_kinematics_after_new_limits_or_hand_eye_checks_them_again() -> None:
    """The entry is kept with the limits and ``eMc`` objects it was found for: new limits
    refuse a ``q`` the old ones took, a new ``eMc`` gives a fresh robot's numbers."""
    robot = Afma6()
    q = robot.limits().center.copy()
    robot.kinematics(q)
    robot.kinematics(q)
    q_max = robot.q_max.copy()
    q_max[2] = q[2] - 0.01
    robot.set_limits(q_max=q_max)
    with pytest.raises(JointLimitError):
        robot.kinematics(q)
    assert robot.kinematics(q, check_limits=False)[0].shape == (4, 4)
    robot.set_limits(q_max=Afma6().q_max)
    eMc = robot.eMc.copy()
    eMc[2, 3] += 0.05
    robot.eMc = eMc
    ref = Afma6()
    ref.eMc = eMc
    for _ in range(3):
        got, want = robot.kinematics(q), ref.kinematics(q)
        assert all(a.tobytes() == b.tobytes() for a, b in zip(got, want, strict=True))


@needs_numba
def test_a_task_checks_its_s_star_and_C_once_and_again_when_they_are_set(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``s*`` and ``C`` are checked on the first evaluation (on main: at every one) and
    again when set anew; the states are the numpy path's to the bit."""
    robot, scene, task, q, _ = _setup(moving=False, base=True, combine=True, seed=21)
    bMc, J = robot.kinematics(q)
    task.evaluate(scene, bMc, J, 0.0)
    task.evaluate(scene, bMc, J, 0.0)
    with monkeypatch.context() as m:
        m.setattr(cp_mod, "_ready", _refuse)
        fast = _bits(task.evaluate(scene, bMc.copy(), J.copy(), 0.0))
    task.s_star = task.s_star + 0.01  # a new s*: checked, and used
    task.C = 2.0 * task.C
    moved = _bits(task.evaluate(scene, bMc, J, 0.0))
    monkeypatch.setattr(cp_mod, "_KT", NUMPY)
    assert moved == _bits(task.evaluate(scene, bMc, J, 0.0))
    task.s_star, task.C = task.s_star - 0.01, 0.5 * task.C
    assert fast == _bits(task.evaluate(scene, bMc, J, 0.0))


@needs_numba
def test_a_task_evaluated_in_another_scene_gives_that_scenes_numbers() -> None:
    """The entry is kept with the scene it was found for; another scene (its base away
    from the world origin) goes through the dispatcher, with its own numbers."""
    robot, scene, task, q, _ = _setup(moving=True, base=False, combine=True, seed=22)
    _, scene2, _, _, _ = _setup(moving=False, base=True, combine=True, seed=22)
    bMc, J = robot.kinematics(q)
    want = [_bits(task.evaluate(s, bMc, J, 0.3)) for s in (scene, scene2)]
    for _ in range(2):
        assert [_bits(task.evaluate(s, bMc, J, 0.3)) for s in (scene, scene2)] == want


@needs_numba
def test_the_law_robot_and_task_pickle_after_repeated_calls_and_give_the_same_numbers() -> None:
    """What they keep between calls holds a kernel's entry point, which does not pickle: a
    pickled copy forgets it and finds it again (on main a law that had been called twice
    could not be pickled, e.g. to send it to a campaign worker)."""
    robot, scene, task, q, _ = _setup(moving=False, base=False, combine=True, seed=23)
    limits = robot.limits()
    law = make_law("iterative-smooth")

    def step(robot: Any, task: Any, law: Any) -> list[bytes]:
        bMc, J = robot.kinematics(q)
        st = task.evaluate(scene, bMc, J, 0.0)
        res = law(J1=st.J1, e1=st.e1, q=q, limits=limits, lam=0.5, dt=0.04)
        return [*_bits(st), res.qdot.tobytes(), repr(res.diagnostics).encode()]

    want = [step(robot, task, law) for _ in range(3)]
    copies = pickle.loads(pickle.dumps((robot, task, law)))
    assert [step(*copies) for _ in range(3)] == want
    assert [step(*copy.deepcopy((robot, task, law))) for _ in range(2)] == want[:2]
