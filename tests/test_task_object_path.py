"""The task's hot path (docs/speed.md, "Public object path"): the points of one target are
measured and differentiated in one kernel call each, the camera pose is validated once per
target, and the results are those of the per-term features to the bit; user input is still
checked with typed errors."""

from __future__ import annotations

import numpy as np
import pytest

from redservo import (
    ConfigurationError,
    GeometryError,
    JointLimitError,
    ShapeError,
    UnknownNameError,
)
from redservo.bench.cases import dh_chain
from redservo.features import LineFeature, PointFeature, SphereFeature
from redservo.features.base import Measurement
from redservo.robots import Afma6
from redservo.scene import ConstantVelocity, PointSet, Scene, Sphere, Static
from redservo.spatial import inverse, make_transform
from redservo.task import TaskTerm, VisualTask

PTS = np.array([[-0.05, -0.04, 0.0], [0.06, -0.05, 0.0], [0.05, 0.05, 0.01], [-0.07, 0.06, 0.0]])
DESIRED = make_transform(t=(0.0, 0.0, 0.6))


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(_bits(a), _bits(b))


def _reference(task, scene, bMc, J, t, *, depth_scale=1.0, noise=None):
    """The per-term evaluation (one cMo, one feature call per term), as before batching."""
    s_parts, d_parts = [], []
    for term in task.terms:
        wMo = scene.object(term.target).trajectory.pose(t)
        cMo = inverse(bMc) @ scene._bMw @ wMo
        m = term.feature.measure(cMo)
        s_parts.append(m.s)
        d_parts.append(m.inv_depth)
    s = np.array(np.concatenate(s_parts), dtype=float)
    if noise is not None:
        s = s + noise
    L_parts, i = [], 0
    for j, term in enumerate(task.terms):
        d = d_parts[j]
        if task.depth != "current":
            star = task.inv_depth_star[j]
            d = star if task.depth == "desired" else 0.5 * (d + star)
        if depth_scale != 1.0:
            d = d / depth_scale
        L_parts.append(term.feature.interaction(s[i : i + term.feature.size], d))
        i += term.feature.size
    L = L_parts[0] if len(L_parts) == 1 else np.vstack(L_parts)
    e = task.error(s)
    if task.C is None:
        return s, e, e, L, L @ J
    return s, e, task.C @ e, L, (task.C @ L) @ J


def _setup(depth="current", *, mixed=False, wMb=None, seed=0):
    robot = Afma6()
    rng = np.random.default_rng(seed)
    lim = robot.limits()
    q = lim.center + rng.uniform(-0.3, 0.3, 6) * lim.range / 2
    front = robot.fkine(q) @ make_transform(t=(0.03, -0.02, 0.7), rotvec=(0.1, -0.05, 0.4))
    wMb = np.eye(4) if wMb is None else wMb
    objs = [PointSet("t", PTS, trajectory=Static(wMb @ front))]
    terms = [TaskTerm(PointFeature(p), "t") for p in PTS]
    desired = {"t": DESIRED}
    if mixed:  # point, point, sphere (another moving target), line, point: five segments
        ball = ConstantVelocity(wMb @ front @ make_transform(t=(0.1, 0.0, 0.1)), v=(0.01, 0, 0))
        objs.append(Sphere("ball", 0.05, trajectory=ball))
        terms = [
            *terms[:2],
            TaskTerm(SphereFeature(0.05), "ball"),
            TaskTerm(LineFeature((0, 0, 0), (1, 0.2, 0)), "t"),
            terms[2],
        ]
        desired["ball"] = DESIRED @ make_transform(t=(0.1, 0.0, 0.1))
    scene = Scene(objs, wMb=wMb)
    task = VisualTask.from_desired_poses(terms, desired, depth=depth)
    return robot, scene, task, q


@pytest.mark.parametrize("depth", ["current", "desired", "mean"])
@pytest.mark.parametrize("mixed", [False, True])
def test_batched_evaluation_is_bit_identical_to_the_per_term_features(depth, mixed) -> None:
    """s, e, e1, L, J1 and the inverse depths equal the per-term path bit for bit, with the
    depth options, a depth-estimate factor, noise, C or not, one target or several."""
    robot, scene, task, q = _setup(depth, mixed=mixed)
    rng = np.random.default_rng(1)
    for i in range(20):
        bMc, J = robot.kinematics(q + rng.normal(0.0, 0.01, 6), check_limits=False)
        t = 0.1 * i
        ds = 1.0 if i % 3 else float(rng.uniform(0.7, 1.4))
        noise = rng.normal(0.0, 1e-3, task.k) if i % 2 else None
        ref = _reference(task, scene, bMc, J, t, depth_scale=ds, noise=noise)
        st = task.evaluate(scene, bMc, J, t, depth_scale=ds, noise=noise)
        for got, want in zip((st.s, st.e, st.e1, st.L, st.J1), ref, strict=True):
            assert _same(got, want)
        again = task.evaluate_measured(st.s, st.inv_depth, J, depth_scale=ds)
        for got, want in zip((again.s, again.e, again.e1, again.L, again.J1), ref, strict=True):
            assert _same(got, want)
        assert _same(task.interaction(st.s, st.inv_depth, depth_scale=ds), ref[3])
        s, inv = task.measure(scene, bMc, t)
        assert len(inv) == len(task.terms)
        if noise is None:
            assert _same(s, st.s)


def test_scene_base_away_from_the_world_origin() -> None:
    """wMb not the identity: cMo keeps the product with bMw, still bit-identical."""
    wMb = make_transform(t=(0.3, -0.2, 0.1), rotvec=(0.0, 0.0, 0.7))
    robot, scene, task, q = _setup(wMb=wMb)
    bMc, J = robot.kinematics(q, check_limits=False)
    st = task.evaluate(scene, bMc, J, 0.0)
    for got, want in zip(st[:5], _reference(task, scene, bMc, J, 0.0), strict=True):
        assert _same(got, want)


def test_inverse_depths_per_term_and_fresh_arrays() -> None:
    robot, scene, task, q = _setup()
    bMc, J = robot.kinematics(q, check_limits=False)
    st = task.evaluate(scene, bMc, J)
    assert len(st.inv_depth) == 4 and all(d.shape == (1,) for d in st.inv_depth)
    Z = (inverse(bMc) @ scene.object("t").trajectory.wMo @ np.c_[PTS, np.ones(4)].T)[2]
    np.testing.assert_allclose(np.concatenate(st.inv_depth), 1.0 / Z, rtol=1e-14)
    before = scene.object("t").trajectory.wMo.copy()
    scene.cMo("t", bMc)[:] = 0.0  # the returned pose is the caller's own array
    assert np.array_equal(scene.object("t").trajectory.wMo, before)


def test_point_behind_the_camera_names_it_as_the_feature_does() -> None:
    robot, scene, task, q = _setup()
    bMc = robot.fkine(q) @ make_transform(t=(0.0, 0.0, 1.5))  # the target is now behind
    with pytest.raises(GeometryError) as got:
        task.evaluate(scene, bMc, robot.jacobian(q))
    with pytest.raises(GeometryError) as want:
        task.terms[0].feature.measure(scene.cMo("t", bMc))
    assert str(got.value) == str(want.value)


def test_user_input_is_still_checked() -> None:
    robot, scene, task, q = _setup()
    bMc, J = robot.kinematics(q, check_limits=False)
    st = task.evaluate(scene, bMc, J)
    with pytest.raises(ShapeError, match="bMc"):
        task.evaluate(scene, np.eye(3), J)
    bad = bMc.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ShapeError, match="bMc"):
        task.evaluate(scene, bad, J)
    with pytest.raises(ConfigurationError, match="time t"):
        task.evaluate(scene, bMc, J, float("nan"))
    with pytest.raises(ShapeError, match="noise"):
        task.evaluate(scene, bMc, J, noise=np.full(task.k, np.nan))
    with pytest.raises(ShapeError, match="J must have shape"):
        task.evaluate(scene, bMc, J[:3])
    with pytest.raises(ConfigurationError, match="depth_scale"):
        task.evaluate(scene, bMc, J, depth_scale=0.0)
    with pytest.raises(UnknownNameError, match="'t'"):
        task.evaluate(Scene([PointSet("other", PTS)]), bMc, J)
    with pytest.raises(ShapeError, match="s must have shape"):
        task.evaluate_measured(st.s[:6], st.inv_depth, J)
    with pytest.raises(ShapeError, match="s must be finite"):
        task.evaluate_measured(np.full(task.k, np.inf), st.inv_depth, J)
    with pytest.raises(ShapeError, match="one entry per term"):
        task.evaluate_measured(st.s, st.inv_depth[:3], J)
    with pytest.raises(ShapeError, match=r"inv_depth\[1\] must have shape \(1,\)"):
        task.evaluate_measured(st.s, (st.inv_depth[0], np.ones(2), *st.inv_depth[2:]), J)
    with pytest.raises(ShapeError, match=r"inv_depth\[2\] must be finite"):
        task.evaluate_measured(st.s, (*st.inv_depth[:2], [np.nan], st.inv_depth[3]), J)
    with pytest.raises(ShapeError, match=r"inv_depth\[0\] must hold numbers"):
        task.evaluate_measured(st.s, (["a"], *st.inv_depth[1:]), J)
    # Lists and integers are numbers like any other.
    lists = task.evaluate_measured(st.s.tolist(), [d.tolist() for d in st.inv_depth], J.tolist())
    np.testing.assert_array_equal(lists.J1, st.J1)


class _MyPoint(PointFeature):
    """A subclass that shifts x: its own measure must be called, not the batched one."""

    def measure(self, cMo):
        m = super().measure(cMo)
        return Measurement(m.s + np.array([0.5, 0.0]), m.inv_depth)


def test_a_subclass_keeps_its_own_measure_and_a_custom_pose_source_is_checked() -> None:
    robot, scene, task, q = _setup()
    bMc, J = robot.kinematics(q, check_limits=False)
    mine = VisualTask([TaskTerm(_MyPoint(p), "t") for p in PTS], task.s_star)
    plain = VisualTask(task.terms, task.s_star)
    shift = mine.evaluate(scene, bMc, J).s - plain.evaluate(scene, bMc, J).s
    np.testing.assert_allclose(shift, np.tile([0.5, 0.0], 4))

    class Poses:  # any object with cMo(name, bMc, t): its poses are user input
        def __init__(self, cMo):
            self.pose = cMo

        def cMo(self, name, bMc, t):
            return self.pose

    good = scene.cMo("t", bMc)
    np.testing.assert_array_equal(
        plain.evaluate(Poses(good), bMc, J).s, plain.measure(scene, bMc, 0.0)[0]
    )
    with pytest.raises(ShapeError, match="cMo must be a homogeneous transform"):
        plain.evaluate(Poses(2.0 * good), bMc, J)

    class Shifted(Scene):  # a scene that overrides cMo is asked, not bypassed
        def cMo(self, name, bMc, t=0.0):
            return super().cMo(name, bMc, t) @ make_transform(t=(0.0, 0.0, 0.1))

    far = Shifted([PointSet("t", PTS, trajectory=scene.object("t").trajectory)])
    assert not np.array_equal(plain.evaluate(far, bMc, J).s, plain.evaluate(scene, bMc, J).s)


@pytest.mark.parametrize("robot", [Afma6(), dh_chain(7)], ids=["afma6", "dh7"])
def test_kinematics_limit_check_inside_at_within_tolerance_and_past(robot) -> None:
    """The float-by-float hot path of the joint check accepts what the numpy check did."""
    lo, hi = robot.q_min, robot.q_max
    for q in (robot.limits().center, lo.copy(), hi.copy(), hi + 5e-10, lo - 5e-10):
        bMc, J = robot.kinematics(q)
        assert bMc.shape == (4, 4) and J.shape == (6, robot.n)
    past = robot.limits().center
    past[2] = hi[2] + 1e-6
    with pytest.raises(JointLimitError, match=repr(robot.joint_names[2])):
        robot.kinematics(past)
    past[2] = np.nan
    with pytest.raises(ShapeError, match="q"):
        robot.kinematics(past)


def test_a_task_pickles_with_its_plan() -> None:
    """Campaign workers receive tasks by pickle: the plan (groups, itemgetters, the trusted
    measure of each single feature) travels with it."""
    import pickle

    robot, scene, task, q = _setup(mixed=True)
    bMc, J = robot.kinematics(q, check_limits=False)
    copy = pickle.loads(pickle.dumps(task))
    for got, want in zip(
        copy.evaluate(scene, bMc, J)[:5], task.evaluate(scene, bMc, J)[:5], strict=True
    ):
        assert _same(got, want)
