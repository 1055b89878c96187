"""What a frame of the image sensor computes once (issue 28, image campaigns' speed): the
PnP pose of a point set is solved once per frame for all the terms of that set, with the
very depths each term got from its own solve."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("cv2", reason="the image sensor needs redservo[vision]")

from redservo.experiment.build import build
from redservo.experiment.camera_presets import camera_overrides
from redservo.scenario import apply_overrides, load_scenario
from redservo.vision import pnp, terms


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
