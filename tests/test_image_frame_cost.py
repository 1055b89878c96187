"""What an image campaign's step computes once (issue 28, image campaigns' speed): the
PnP pose of a point set is solved once per frame for all the terms of that set, with the
very depths each term got from its own solve; the latency compensation reads only the
commands the camera has not seen, with the same sum; the predicted image motion normalizes
the dots once."""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import pytest

pytest.importorskip("cv2", reason="the image sensor needs redservo[vision]")

from redservo._validation import FloatArray
from redservo.control.latency import CommandHistory
from redservo.experiment.build import build
from redservo.experiment.camera_presets import camera_overrides
from redservo.scenario import apply_overrides, load_scenario
from redservo.vision import pnp, terms
from redservo.vision.motion import camera_shift, predicted_shift
from redservo.vision.optics import Optics
from redservo.vision.terms import TermState


def _reads(exp: Any, frames: int) -> list[Any]:
    """The image sensor's readings of ``frames`` frames while the robot moves a little."""
    sensor = exp.sensor.sensor
    sensor.reset()
    out = []
    for k in range(frames):
        q = exp.q0 + 0.002 * k
        bMc = exp.robot.kinematics(q, check_limits=False)[0]
        out.append(sensor.read(exp.task, exp.scene, bMc, 0.04 * k))
    return out


def test_one_pnp_solve_per_point_set_and_frame(monkeypatch: pytest.MonkeyPatch) -> None:
    """panda-4points (four point terms of one target) through the realistic preset: one
    ``dot_pose`` per frame (four before, one per term), and every reading's depths the
    ones of a solve per term (``poses`` not shared), bit for bit."""
    exp = build(apply_overrides(load_scenario("panda-4points"), camera_overrides("realistic")))
    assert len(exp.task.terms) == 4 and exp.sensor.sensor.depth == "pose"
    calls = [0]
    solve = pnp.dot_pose

    def counted(*args: Any, **kw: Any) -> Any:
        calls[0] += 1
        return solve(*args, **kw)

    monkeypatch.setattr(pnp, "dot_pose", counted)
    shared = _reads(exp, 6)
    assert calls[0] == 6, calls
    per_term = terms.pose_term_depth

    def alone(*args: Any) -> Any:
        return per_term(*args[:6])  # no shared poses: each term solves its own

    monkeypatch.setattr(terms, "pose_term_depth", alone)
    calls[0] = 0
    single = _reads(exp, 6)
    assert calls[0] == 24, calls
    for a, b in zip(shared, single):
        assert a.s is not None and np.array_equal(a.s, b.s)
        assert len(a.inv_depth) == 4
        for da, db in zip(a.inv_depth, b.inv_depth):
            assert np.array_equal(da, db)


class _Counted(deque):  # type: ignore[type-arg]
    """A deque that counts the commands read by index or iteration."""

    reads = 0

    def __getitem__(self, i: Any) -> Any:
        _Counted.reads += 1
        return super().__getitem__(i)

    def __iter__(self) -> Any:
        for x in super().__iter__():
            _Counted.reads += 1
            yield x


def _history(times: list[float], rng: np.random.Generator) -> CommandHistory:
    h = CommandHistory(0.04, lambda q: np.outer(np.arange(1.0, 7.0), q), horizon=10.0)
    for t in times:
        h.record(t, rng.normal(size=3), rng.normal(size=3))
    return h


def test_latency_motion_reads_only_the_commands_after_the_stamp() -> None:
    """The compensation's sum reads the few commands the camera has not seen (a 66 ms
    latency: 4 of 100), not the whole history, with the same sum bit for bit as every
    command looked at; commands recorded out of time order are all looked at."""
    times = [0.04 * k for k in range(100)]
    hist = _history(times, np.random.default_rng(3))
    ref = _history(times, np.random.default_rng(3))
    counted = _Counted(hist._cmds)
    hist._cmds = counted
    _Counted.reads = 0
    got = hist.motion(3.96 - 0.066, 3.96)
    assert _Counted.reads <= 12, _Counted.reads  # every command read: 100
    assert np.array_equal(got, _sum_all(ref, 3.96 - 0.066, 3.96))
    shuffled = _history([0.0, 0.08, 0.04, 0.12], np.random.default_rng(4))
    assert np.array_equal(shuffled.motion(0.02, 0.16), _sum_all(shuffled, 0.02, 0.16))


def _sum_all(h: CommandHistory, stamp: float, now: float) -> FloatArray:
    """The module docstring's sum over every command, in order."""
    cmds = list(h._cmds)
    total = np.zeros(6)
    for i, cmd in enumerate(cmds):
        end = cmds[i + 1].t if i + 1 < len(cmds) else cmd.t + h.period
        overlap = min(end, now) - max(cmd.t, stamp)
        if overlap > 1e-9:
            total += (h.jacobian(cmd.q) @ cmd.qdot) * overlap
    return total


def test_the_predicted_image_motion_normalizes_the_dots_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``camera_shift`` turns the dots' pixels into normalized coordinates once (twice
    before: for the depths and again for the motion), with the same shifts as the general
    path (a dot without a depth, a dot behind the new camera) bit for bit."""
    optics = Optics()
    uv = np.array([[300.0, 200.0], [340.0, 260.0], [280.0, 250.0], [330.0, 190.0]])
    st = TermState(kind="point", dots=np.arange(4))
    st.inv_depth = np.array([2.0])
    b0 = np.eye(4)
    b1 = np.eye(4)
    b1[:3, 3] = [0.01, -0.02, 0.005]
    calls = [0]
    real = Optics.to_normalized

    def counted(self: Optics, x: Any) -> Any:
        calls[0] += 1
        return real(self, x)

    monkeypatch.setattr(Optics, "to_normalized", counted)
    got = camera_shift([st], optics, uv, b0, b1)
    assert calls[0] <= 1, calls  # 0: normalized in the compiled call (kernels/dot_shift)
    rho = np.full(4, 2.0)
    rho[1] = np.nan  # no depth: NaN, the tracker's own prediction
    partial = predicted_shift(optics, uv, rho, b0, b1)
    assert got is not None and np.isfinite(got).all()
    assert np.array_equal(partial[[0, 2, 3]], got[[0, 2, 3]]) and np.isnan(partial[1]).all()
    far = b1.copy()
    far[2, 3] = 0.6  # the camera moved 0.6 m forward: the dots (at 0.5 m) behind it
    assert np.isnan(predicted_shift(optics, uv, np.full(4, 2.0), b0, far)).all()


def test_a_feature_degenerate_at_the_pnp_pose_keeps_its_last_depths(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``depth = "pose"``: a term whose feature cannot be measured at the frame's PnP pose
    (a moment invariant vanishes there: GeometryError) keeps its last parameters, as with
    ``depth = "estimated"``, instead of ending the run with the exception (mc05-joint-limits
    sample 141 through the camera crashed so in an experiment)."""
    from redservo.errors import GeometryError

    exp = build(apply_overrides(load_scenario("panda-4points"), camera_overrides("realistic")))
    before = _reads(exp, 3)
    feature = type(exp.task.terms[0].feature)

    def degenerate(self: Any, cMo: Any) -> Any:
        raise GeometryError("the invariant vanishes at this pose")

    monkeypatch.setattr(feature, "_measure_trusted", degenerate)
    sensor = exp.sensor.sensor
    bMc = exp.robot.kinematics(exp.q0 + 0.006, check_limits=False)[0]
    got = sensor.read(exp.task, exp.scene, bMc, 0.12)
    assert got.s is not None and len(got.inv_depth) == 4
    for kept, last in zip(got.inv_depth, before[-1].inv_depth):
        assert np.array_equal(kept, last)
