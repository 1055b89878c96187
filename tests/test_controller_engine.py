"""The Controller's compiled engine equals its object path bit for bit (issue 18, item 1).

For every method with a compiled controller step, on the Afma6, a DH chain (the Panda), a
URDF chain, and a robot whose Jacobian comes from Python: the command, the task state and
the diagnostics of ``Controller(engine="compiled")`` are those of ``engine="python"``, over a
closed loop that reaches the limits (the shield, the rate limits and the flags act), with
the depth options, a combination matrix and a known feed-forward.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

from redservo import METHODS, AdaptiveGain, ConfigurationError, Controller, JointLimits, make_law
from redservo.control import Measurement, SceneContext
from redservo.features import PointFeature
from redservo.robots import Afma6, Panda
from redservo.scene import ConstantVelocity, PointSet, Scene
from redservo.spatial import make_transform
from redservo.task import TaskTerm, VisualTask

PTS = np.array([[-0.05, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0.0]])
S_STAR = np.array([-0.1, -0.1, 0.1, -0.1, 0.1, 0.1, -0.1, 0.1])
COMPILED = [m for m in METHODS if m not in ("qp-goal", "sns", "predictive")]


def _same(a: Any, b: Any) -> bool:
    if dataclasses.is_dataclass(a):
        fa, fb = dataclasses.asdict(a), dataclasses.asdict(b)  # type: ignore[arg-type]
        return fa.keys() == fb.keys() and all(_same(fa[k], fb[k]) for k in fa)
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, tuple | list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray | float) or isinstance(b, np.ndarray):
        return np.array_equal(
            np.asarray(a, dtype=float), np.asarray(b, dtype=float), equal_nan=True
        )
    return bool(a == b)


def _robot(kind: str) -> Any:
    if kind == "afma6":
        return Afma6()
    if kind == "panda":
        return Panda()
    if kind == "urdf":
        from redservo.robots.urdf import URDFRobot, shipped_urdf

        return URDFRobot(shipped_urdf("panda"), camera_link="camera_link")
    return Humanoidish()


class Humanoidish(Afma6):
    """An Afma6 seen as a robot without compiled kinematics (its own class)."""


def _loop(
    kind: str, method: str, *, depth: str = "current", C: bool = False, v: float = 0.0,
    lam: Any = 0.6,
):  # fmt: skip
    """Run both engines side by side from a start near the limits; yield both steps."""
    robot = _robot(kind)
    lim = robot.limits()
    limits = JointLimits(lim.q_min, lim.q_max, rho=0.1, qdot_max=0.5, qddot_max=4.0)
    q = lim.center + 0.8 * lim.range / 2 * np.sign(np.arange(robot.n) % 2 - 0.5)
    wMo = robot.fkine(q) @ make_transform(t=(0.04, -0.03, 0.6), rotvec=(0.0, 0.0, 0.9))
    traj = ConstantVelocity(wMo, v=np.array([0.0, v, 0.0]))
    scene = Scene([PointSet("sq", PTS, trajectory=traj)])
    terms = [TaskTerm(PointFeature(p), "sq") for p in PTS]
    Cm = np.linalg.qr(np.random.default_rng(3).normal(size=(8, 8)))[0][:6] if C else None
    star = None if depth == "current" else tuple(np.array([1.0 / 0.5]) for _ in PTS)
    task = VisualTask(terms, S_STAR, depth=depth, C=Cm, inv_depth_star=star)
    ff = "known" if v else "none"
    ctl = {
        e: Controller(robot, task, make_law(method), limits, lam=lam, dt=0.04, feedforward=ff,
                      engine=e)
        for e in ("compiled", "python")
    }  # fmt: skip
    prev = None
    for i in range(40):
        t = 0.04 * i
        bMc = robot.fkine(q, check_limits=False)
        s, inv = task.measure(scene, bMc, t)
        ctx = SceneContext(scene, bMc)
        a = ctl["compiled"].step(q, Measurement(s, inv), t, qdot_prev=prev, context=ctx)
        b = ctl["python"].step(q, Measurement(s, inv), t, qdot_prev=prev, context=ctx)
        yield a, b
        prev = a.qdot.copy()
        q = q + 0.04 * prev


@pytest.mark.parametrize("method", COMPILED)
@pytest.mark.parametrize("kind", ["afma6", "panda", "urdf", "python-jacobian"])
def test_compiled_controller_is_the_object_path_bit_for_bit(kind: str, method: str) -> None:
    flagged = 0
    for a, b in _loop(kind, method):
        assert np.array_equal(a.qdot, b.qdot), (kind, method)
        assert all(_same(x, y) for x, y in zip(a.state, b.state))
        assert _same(a.diagnostics, b.diagnostics), (a.diagnostics, b.diagnostics)
        flagged += bool(a.diagnostics.events)
    assert flagged > 0  # the loop exercised the flag rules


@pytest.mark.parametrize("method", ["classical", "iterative-smooth", "directional"])
@pytest.mark.parametrize(("depth", "C", "v"), [("desired", False, 0.0), ("mean", True, 0.02)])
def test_depth_options_combination_and_feedforward(method: str, depth: str, C: bool, v: float):
    for a, b in _loop("afma6", method, depth=depth, C=C, v=v):
        assert np.array_equal(a.qdot, b.qdot)
        assert np.array_equal(a.state.J1, b.state.J1) and np.array_equal(a.state.e1, b.state.e1)
        assert _same(a.diagnostics, b.diagnostics)
        assert (a.de1_dt is None) == (v == 0.0)


@pytest.mark.parametrize("method", ["gpm-auto", "iterative-smooth"])
def test_adaptive_gain(method: str) -> None:
    """λ(‖e1‖∞) (AdaptiveGain) is evaluated as the law evaluates it."""
    gain = AdaptiveGain(zero=1.2, inf=0.3, slope=8.0)
    for i, (a, b) in enumerate(_loop("panda", method, C=True, lam=gain)):
        assert np.array_equal(a.qdot, b.qdot), i
        assert _same(a.diagnostics, b.diagnostics)


@pytest.mark.parametrize("method", ["wln", "qp"])
@pytest.mark.parametrize("kind", ["panda", "urdf"])
def test_latency_compensation_is_the_object_paths(kind: str, method: str) -> None:
    """Measurements stamped 66 ms before the step (a camera's latency): the compiled engine
    (the twists of the unseen commands from the robot's compiled kinematics, the points
    brought to the present in one kernel) gives the object path's steps bit for bit."""
    robot = _robot(kind)
    lim = robot.limits()
    limits = JointLimits(lim.q_min, lim.q_max, rho=0.1, qdot_max=0.5, qddot_max=4.0)
    q = lim.center + 0.6 * lim.range / 2 * np.sign(np.arange(robot.n) % 2 - 0.5)
    wMo = robot.fkine(q) @ make_transform(t=(0.04, -0.03, 0.6), rotvec=(0.0, 0.0, 0.9))
    scene = Scene([PointSet("sq", PTS, trajectory=ConstantVelocity(wMo, v=np.zeros(3)))])
    task = VisualTask([TaskTerm(PointFeature(p), "sq") for p in PTS], S_STAR)
    ctl = {
        e: Controller(robot, task, make_law(method), limits, lam=0.6, dt=0.04, engine=e)
        for e in ("compiled", "python")
    }
    assert ctl["compiled"].engine == "compiled"
    prev, seen = None, []
    for i in range(30):
        t = 0.04 * i
        stamp = max(0.0, t - 0.066)
        s, inv = task.measure(scene, robot.fkine(q, check_limits=False), stamp)
        a, b = (c.step(q, Measurement(s, inv, stamp), t, qdot_prev=prev) for c in ctl.values())
        assert a.qdot.tobytes() == b.qdot.tobytes(), i
        assert a.state.s.tobytes() == b.state.s.tobytes(), i  # the features brought to t
        assert _same(a.diagnostics, b.diagnostics)
        seen.append(bool(np.any(a.state.s != s)))
        prev = a.qdot.copy()
        q = q + 0.04 * prev
    assert sum(seen) > 20  # compensated steps


def test_engine_is_said_and_the_reason_is_one_line() -> None:
    robot = Afma6()
    terms = [TaskTerm(PointFeature(p), "sq") for p in PTS]
    task = VisualTask(terms, S_STAR)
    assert Controller(robot, task, make_law("gpm"), lam=0.5, dt=0.04).engine == "compiled"
    sns = Controller(robot, task, make_law("sns"), lam=0.5, dt=0.04)
    assert sns.engine == "kernels" and "sns" in sns.engine_reason
    assert "\n" not in sns.engine_reason

    def mine(**kw: Any) -> Any:
        return make_law("classical")(**kw)

    user = Controller(robot, task, mine, lam=0.5, dt=0.04)
    assert user.engine == "python" and "mine" in user.engine_reason
    with pytest.raises(ConfigurationError) as err:
        Controller(robot, task, make_law("sns"), lam=0.5, dt=0.04, engine="compiled")
    assert err.value.argument == "engine"
    py = Controller(robot, task, make_law("gpm"), lam=0.5, dt=0.04, engine="python")
    assert py.engine == "kernels" and py.engine_reason == "engine='python' asked for"


@pytest.mark.parametrize("method", ["classical", "qp"])
def test_bad_inputs_raise_the_object_paths_errors(method: str) -> None:
    """A joint outside its limits or a NaN feature: the compiled engine hands the step to the
    object path, whose error names the input."""
    from redservo import JointLimitError, ShapeError

    robot = Afma6()
    terms = [TaskTerm(PointFeature(p), "sq") for p in PTS]
    task = VisualTask(terms, S_STAR)
    ctl = Controller(robot, task, make_law(method), lam=0.5, dt=0.04)
    assert ctl.engine == "compiled"
    q = robot.limits().center.copy()
    meas = Measurement(S_STAR + 0.01, tuple(np.array([1.5]) for _ in PTS))
    assert ctl.step(q, meas, 0.0, qdot_prev=None).qdot.shape == (6,)
    q_out = q.copy()
    q_out[1] = robot.limits().q_max[1] + 0.1
    with pytest.raises(JointLimitError):
        ctl.step(q_out, meas, 0.0, qdot_prev=None)
    bad = Measurement(np.full(8, np.nan), meas.inv_depth)
    with pytest.raises(ShapeError):
        ctl.step(q, bad, 0.0, qdot_prev=None)


def test_qp_is_compiled_with_its_own_solver_and_without_distance_rows() -> None:
    """``qp`` has a compiled controller step with its compiled solver (``solver="auto"``);
    a solver library, distance rows (collision avoidance) or ``qp-goal`` keep the object
    path and say why; a law given a library or rows after the binding is bound anew."""
    from redservo.collision.shapes import Obstacle, Shape
    from redservo.control.avoidance import Collision
    from redservo.redundancy.distance_rows import bind_distances
    from redservo.scene import Static

    robot = Panda()
    task = VisualTask([TaskTerm(PointFeature(p), "sq") for p in PTS], S_STAR)
    q = robot.limits().center.copy()
    meas = Measurement(S_STAR + 0.01, tuple(np.array([1.5]) for _ in PTS))

    def ctl(law: Any) -> Controller:
        return Controller(robot, task, law, lam=0.5, dt=0.04)

    assert (ctl(make_law("qp")).engine, ctl(make_law("qp")).engine_reason) == ("compiled", "")
    lib = ctl(make_law("qp", solver="scipy"))
    assert lib.engine == "kernels" and "'scipy'" in lib.engine_reason
    assert "'qp-goal'" in ctl(make_law("qp-goal")).engine_reason
    later = ctl(make_law("qp"))
    later.law.solver = "scipy"  # type: ignore[attr-defined]
    later.step(q, meas, 0.0, qdot_prev=None)
    assert later.engine == "kernels" and "'scipy'" in later.engine_reason
    rows = ctl(make_law("qp"))
    post = Obstacle("post", Shape("sphere", radius=0.05), Static(np.eye(4)))
    bind_distances(rows.law, Collision(obstacles=(post,)), robot)
    rows.step(q, meas, 0.0, qdot_prev=None)
    assert rows.engine == "kernels" and "distance rows" in rows.engine_reason


def test_run_json_records_the_engine(tmp_path: Any, capsys: pytest.CaptureFixture[str]) -> None:
    """run.json says which engine ran and why not compiled; the command line says it in one
    line only when a user's own Python code took part."""
    import json

    import redservo
    from redservo.cli.common import engine_note

    res = redservo.run("cm01-gaze", out=tmp_path / "gaze", max_iterations=5)
    meta = json.loads((tmp_path / "gaze" / "run.json").read_text())
    assert (meta["engine"], meta["engine_reason"]) == ("compiled", "")
    res = redservo.run("mc05-occlusion", out=tmp_path / "occ", max_iterations=5)
    meta = json.loads((tmp_path / "occ" / "run.json").read_text())
    assert meta["engine"] == "kernels" and "objectives" in meta["engine_reason"]
    engine_note(res)
    assert capsys.readouterr().err == ""
    engine_note(type("R", (), {"engine": "python", "engine_reason": "written in Python: x"})())
    assert capsys.readouterr().err == "note: Python control step (written in Python: x)\n"
