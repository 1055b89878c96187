"""The object path's compiled hot paths (issue 29 item 3): ``task.evaluate`` of the points of
one target in one kernel call (kernels/points_task.py) and the robots' joint check inside
the kinematics kernel (kernels/joint_check.py). Their numbers are the numpy path's to the
bit, and every malformed input still gets the Python check's one error."""

from __future__ import annotations

import types
from typing import Any

import numpy as np
import pytest

import redservo.features.compiled_points as cp_mod
import redservo.robots.afma6 as afma6_mod
import redservo.robots.dh as dh_mod
import redservo.scene as scene_mod
import redservo.task as task_mod
from redservo import ConfigurationError, GeometryError, JointLimitError, ShapeError
from redservo.bench.cases import dh_chain
from redservo.features import PointFeature
from redservo.kernels import compiled
from redservo.robots import Afma6
from redservo.scene import ConstantVelocity, PointSet, Scene, Static
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

pytestmark = pytest.mark.skipif(not compiled(), reason="the compiled paths need numba")

PTS = np.array([[-0.05, -0.04, 0.0], [0.06, -0.05, 0.0], [0.05, 0.05, 0.01], [-0.07, 0.06, 0.0]])
NUMPY = types.SimpleNamespace(COMPILED=False)
"""A kernel handle that says "not compiled": the numpy path of the same process."""


def _setup(*, moving: bool, base: bool, combine: bool, seed: int) -> tuple[Any, ...]:
    robot = Afma6()
    rng = np.random.default_rng(seed)
    lim = robot.limits()
    q = lim.center + rng.uniform(-0.3, 0.3, 6) * lim.range / 2
    wMb = make_transform(t=(0.3, -0.2, 0.1), rotvec=(0.0, 0.0, 0.7)) if base else np.eye(4)
    front = wMb @ robot.fkine(q) @ make_transform(t=(0.03, -0.02, 0.7), rotvec=(0.1, -0.05, 0.4))
    traj = ConstantVelocity(front, v=(0.01, 0.0, 0.02), w=(0.0, 0.1, 0.0)) if moving else None
    scene = Scene([PointSet("t", PTS, trajectory=traj or Static(front))], wMb=wMb)
    terms = [TaskTerm(PointFeature(p), "t") for p in PTS]
    task = VisualTask.from_desired_poses(terms, {"t": make_transform(t=(0, 0, 0.6))})
    if not combine:  # no combination matrix: e1 = e
        task = VisualTask(terms, task.s_star)
    assert (task.C is not None) == combine
    return robot, scene, task, q, rng


def _bits(state: Any) -> list[bytes]:
    arrays = [state.s, state.e, state.e1, state.L, state.J1, *state.inv_depth]
    return [np.ascontiguousarray(a).tobytes() for a in arrays] + [
        str([a.shape for a in arrays]).encode()
    ]


@pytest.mark.parametrize("moving", [False, True], ids=["static", "moving"])
@pytest.mark.parametrize("base", [False, True], ids=["base-at-origin", "base-away"])
@pytest.mark.parametrize("combine", [False, True], ids=["no-C", "C"])
def test_the_kernel_path_equals_the_numpy_path_to_the_bit(
    monkeypatch: pytest.MonkeyPatch, moving: bool, base: bool, combine: bool
) -> None:
    robot, scene, task, q0, rng = _setup(moving=moving, base=base, combine=combine, seed=3)
    lim = robot.limits()
    cases = []
    for _ in range(200):
        q = np.clip(q0 + rng.normal(scale=0.05, size=6) * lim.range, lim.q_min, lim.q_max)
        bMc, J = robot.kinematics(q)
        t = float(rng.uniform(0.0, 2.0))
        cases.append((bMc, J, t, _bits(task.evaluate(scene, bMc, J, t))))
    monkeypatch.setattr(cp_mod, "_KT", NUMPY)
    for bMc, J, t, fast in cases:
        assert _bits(task.evaluate(scene, bMc, J, t)) == fast
    if not combine:  # e1 is e itself, as on the numpy path
        st = task.evaluate(scene, *cases[0][:3])
        assert st.e1 is st.e


def test_evaluate_runs_one_kernel_call_on_the_common_task(monkeypatch: pytest.MonkeyPatch) -> None:
    robot, scene, task, q, _ = _setup(moving=False, base=False, combine=True, seed=0)
    bMc, J = robot.kinematics(q)
    real = cp_mod._KT.points_task
    calls = []

    def spy(*args: Any) -> Any:
        calls.append(len(args))
        return real(*args)

    monkeypatch.setattr(cp_mod._KT, "points_task", spy)
    monkeypatch.setattr(task_mod._K, "points_interaction", None)  # not called any more
    monkeypatch.setattr(scene_mod, "as_transform", None)  # bMc is checked in the kernel
    task.evaluate(scene, bMc, J, 0.0)
    assert calls == [8]  # the points, s*, C, J and the arrays it writes into


def test_inputs_the_kernel_does_not_take_get_the_numpy_path_and_its_errors(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    robot, scene, task, q, _ = _setup(moving=False, base=False, combine=True, seed=1)
    bMc, J = robot.kinematics(q)
    # Other layouts and types of valid values: the numbers of the numpy path.
    inputs = [(bMc, J, 0.0), (bMc.tolist(), J.tolist(), 0.0), (bMc, J, 0)]
    inputs.append((np.asfortranarray(bMc), np.asfortranarray(J), 0.0))
    fast = [_bits(task.evaluate(scene, *x)) for x in inputs]
    with monkeypatch.context() as m:
        m.setattr(cp_mod, "_KT", NUMPY)
        assert fast == [_bits(task.evaluate(scene, *x)) for x in inputs]
    # Malformed input: the one error of the Python checks.
    with pytest.raises(ShapeError, match="bMc must be finite"):
        task.evaluate(scene, np.where(np.eye(4) > 0, np.nan, bMc), J)
    with pytest.raises(ShapeError, match="bMc must be a homogeneous transform"):
        task.evaluate(scene, 2.0 * bMc, J)
    with pytest.raises(ShapeError, match="J must have shape"):
        task.evaluate(scene, bMc, J[:3])
    with pytest.raises(ConfigurationError, match="time t"):
        task.evaluate(scene, bMc, J, float("inf"))
    behind = bMc @ make_transform(rotvec=(np.pi, 0.0, 0.0))  # the camera turned around
    with pytest.raises(GeometryError, match="behind"):
        task.evaluate(scene, behind, J)


@pytest.mark.parametrize("robot", [Afma6(), dh_chain(7)], ids=["afma6", "dh7"])
def test_the_compiled_joint_check_gives_the_python_checks_numbers_and_errors(
    monkeypatch: pytest.MonkeyPatch, robot: Any
) -> None:
    lim = robot.limits()
    rng = np.random.default_rng(5)
    qs = [lim.center + rng.uniform(-1, 1, robot.n) * lim.range / 2 for _ in range(50)]
    qs += [lim.q_min.copy(), lim.q_max.copy(), lim.q_max + 5e-10, lim.q_min - 5e-10]
    fast = [[a.tobytes() for a in robot.kinematics(q)] for q in qs]
    nocheck = [[a.tobytes() for a in robot.kinematics(q + 1.0, check_limits=False)] for q in qs]
    monkeypatch.setattr(afma6_mod, "_KJ", NUMPY)
    monkeypatch.setattr(dh_mod, "_KJ", NUMPY)
    assert fast == [[a.tobytes() for a in robot.kinematics(q)] for q in qs]
    assert nocheck == [
        [a.tobytes() for a in robot.kinematics(q + 1.0, check_limits=False)] for q in qs
    ]
    monkeypatch.undo()
    past = lim.center
    past[4] = lim.q_max[4] + 1e-6
    with pytest.raises(JointLimitError, match=repr(robot.joint_names[4])):
        robot.kinematics(past)
    for bad in (np.nan, np.inf, -np.inf):
        past[4] = bad
        with pytest.raises(ShapeError, match="q must be finite"):
            robot.kinematics(past)
        with pytest.raises(ShapeError, match="q must be finite"):
            robot.kinematics(past, check_limits=False)
    with pytest.raises(ShapeError, match="q must have shape"):
        robot.kinematics(lim.center[:-1])


@pytest.mark.parametrize("robot", [Afma6(), dh_chain(7)], ids=["afma6", "dh7"])
def test_a_valid_float64_q_is_checked_in_compiled_code(
    monkeypatch: pytest.MonkeyPatch, robot: Any
) -> None:
    q = robot.limits().center
    expected = [a.tobytes() for a in robot.kinematics(q)]

    def python_check(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("the Python joint check ran on a valid float64 q")

    monkeypatch.setattr(dh_mod, "as_vector", python_check)  # the Python check's first step
    assert [a.tobytes() for a in robot.kinematics(q)] == expected
    assert robot.check_q(q) is q
    with pytest.raises(AssertionError, match="Python joint check"):
        robot.kinematics(q.tolist())  # a list still goes through the Python check


def _perturbed(bMc: np.ndarray, row_scale: float = 1.0, bottom: float = 0.0) -> np.ndarray:
    T = bMc.copy()
    T[0, :3] *= row_scale  # |row 0|² - 1 ≈ 2 (row_scale - 1)
    T[3, 0] = bottom
    return T


@pytest.mark.parametrize(
    "change",
    [
        {"row_scale": 1 + 0.35e-6},  # within as_transform's 1e-6, outside the kernel's 0.5e-6
        {"bottom": 0.7e-9},  # within 1e-9, outside the kernel's 0.5e-9
        {"bottom": -1e-9},  # at as_transform's tolerance
        {"row_scale": 1 + 0.1e-6},  # within both
    ],
)
def test_a_pose_within_the_full_tolerances_is_accepted_with_the_numpy_numbers(
    monkeypatch: pytest.MonkeyPatch, change: dict[str, float]
) -> None:
    robot, scene, task, q, _ = _setup(moving=False, base=False, combine=True, seed=2)
    bMc, J = robot.kinematics(q)
    T = _perturbed(bMc, **change)
    fast = _bits(task.evaluate(scene, T, J))
    monkeypatch.setattr(cp_mod, "_KT", NUMPY)
    assert _bits(task.evaluate(scene, T, J)) == fast


def test_a_bad_pose_gets_the_python_checks_error_in_their_order() -> None:
    robot, scene, task, q, _ = _setup(moving=False, base=False, combine=True, seed=2)
    bMc, J = robot.kinematics(q)
    for T in (
        _perturbed(bMc, row_scale=1 + 2e-6),
        _perturbed(bMc, bottom=2e-9),
        bMc @ np.diag([1.0, 1.0, -1.0, 1.0]),  # a reflection
    ):
        with pytest.raises(ShapeError, match="bMc must be a homogeneous transform"):
            task.evaluate(scene, T, J)
    T = bMc.copy()
    T[1, 3] = np.inf
    with pytest.raises(ShapeError, match="bMc must be finite"):
        task.evaluate(scene, T, J)
    other = Scene([PointSet("other", PTS)])  # the task's target is missing: bMc named first
    with pytest.raises(ShapeError, match="bMc must be finite"):
        task.evaluate(other, T, J)
    with pytest.raises(ShapeError, match="bMc must be finite"):
        task.evaluate(scene, T, J, float("nan"))


@pytest.mark.parametrize("depth", ["current", "desired", "mean"])
@pytest.mark.parametrize("combine", [False, True], ids=["no-C", "C"])
def test_depth_options_and_measured_features_give_the_numpy_numbers(
    monkeypatch: pytest.MonkeyPatch, depth: str, combine: bool
) -> None:
    robot, scene, base, q0, rng = _setup(moving=False, base=False, combine=True, seed=4)
    task = VisualTask(
        base.terms, base.s_star, inv_depth_star=base.inv_depth_star, depth=depth, C=base.C
    )
    if not combine:
        task = VisualTask(base.terms, base.s_star, inv_depth_star=base.inv_depth_star, depth=depth)
        task.C = None
    lim = robot.limits()
    cases = []
    for _ in range(100):
        q = np.clip(q0 + rng.normal(scale=0.05, size=6) * lim.range / 2, lim.q_min, lim.q_max)
        bMc, J = robot.kinematics(q)
        st = task.evaluate(scene, bMc, J)
        scale = float(rng.choice([1.0, 0.8, 1.3]))
        s = st.s + rng.normal(scale=1e-3, size=st.s.shape)
        cases.append((bMc, J, s, st.inv_depth, scale))
    got = [
        (
            _bits(task.evaluate(scene, b, J, depth_scale=d)),
            _bits(task.evaluate_measured(s, iz, J, depth_scale=d)),
        )
        for b, J, s, iz, d in cases
    ]
    monkeypatch.setattr(cp_mod, "_KT", NUMPY)
    want = [
        (
            _bits(task.evaluate(scene, b, J, depth_scale=d)),
            _bits(task.evaluate_measured(s, iz, J, depth_scale=d)),
        )
        for b, J, s, iz, d in cases
    ]
    assert got == want
