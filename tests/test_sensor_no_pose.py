"""The image sensor's own PnP (``sensor.depth = "pose"``, the ``realistic`` camera preset): a
frame whose dots give no pose is the typed flag ``no-pose`` (value: the frames in a row), the
same flag as the ``predictive`` law's PnP, in the reading, the step's diagnostics, the run's
log and summary and the campaign's flag counts; the depths used meanwhile are the last
pose's, and the message says so."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("cv2", reason="the image sensor needs redservo[vision]")

from redservo.campaign import draw_sample, load_campaign, run_campaign
from redservo.experiment.build import build
from redservo.experiment.camera_presets import camera_overrides
from redservo.redundancy.base import Diagnostics
from redservo.redundancy.flags import Flag
from redservo.scenario import apply_overrides, load_scenario
from redservo.sensors import NoPose, SensorReading
from redservo.sensors.flags import no_pose_event, sensor_flags
from redservo.vision import pnp

FAIL = (3, 4, 5)
"""The PnP solves (1-based, one per frame and point set) forced to give no pose."""


def _failing(monkeypatch: pytest.MonkeyPatch, fail: Any = FAIL.__contains__) -> list[int]:
    """``pnp.set_pose`` giving no pose on the solves ``fail(k)`` (k 1-based); returns the
    solve counter."""
    calls = [0]
    solve = pnp.set_pose

    def forced(*args: Any) -> Any:
        calls[0] += 1
        return None if fail(calls[0]) else solve(*args)

    monkeypatch.setattr(pnp, "set_pose", forced)
    return calls


def _realistic(name: str, *extra: str) -> Any:
    return build(apply_overrides(load_scenario(name), [*camera_overrides("realistic"), *extra]))


def test_reading_says_the_frames_in_a_row_without_a_pose_and_keeps_the_last_depths(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    exp = _realistic("panda-4points")
    sensor = exp.sensor.sensor  # the image sensor inside the camera's timing
    assert sensor.depth == "pose"
    _failing(monkeypatch)
    sensor.reset()
    readings: list[SensorReading] = []
    for k in range(8):
        bMc = exp.robot.kinematics(exp.q0 + 0.002 * k, check_limits=False)[0]
        readings.append(sensor.read(exp.task, exp.scene, bMc, 0.04 * k))
    misses = [r.no_pose for r in readings]
    assert misses[:2] == [None, None] and misses[5:] == [None, None, None]
    assert [m.frames for m in misses[2:5] if m is not None] == [1, 2, 3]
    miss = misses[4]
    assert miss == NoPose(3, "target", 4, 4)
    for r in readings[2:5]:  # the depths of the last pose (frame 2's), bit for bit
        assert all(np.array_equal(a, b) for a, b in zip(r.inv_depth, readings[1].inv_depth))
    assert not np.array_equal(readings[5].inv_depth[0], readings[1].inv_depth[0])
    sensor.reset()
    assert sensor._pose_misses.in_a_row == {}


def test_no_pose_event_message_names_the_target_the_dots_and_the_depths_kept() -> None:
    ev = no_pose_event(NoPose(2, "target", 3, 4))
    assert ev.flag is Flag.NO_POSE and ev.value == 2.0
    assert "'target'" in ev.message and "3 detected dot(s) of its 4" in ev.message
    assert "2 frame(s) in a row" in ev.message and "depths of the last pose" in ev.message
    ev = no_pose_event(NoPose(1, "target", 4, 4))
    assert "reprojection tolerance" in ev.message and "depths of the last pose" in ev.message
    d = Diagnostics(method="wln")
    assert sensor_flags(d, SensorReading(np.zeros(2), ())) is d
    (got,) = sensor_flags(d, SensorReading(np.zeros(2), (), no_pose=NoPose(2, "t", 4, 4))).events
    assert got.flag is Flag.NO_POSE and got.value == 2.0


def test_too_few_detected_dots_is_a_no_pose_too(monkeypatch: pytest.MonkeyPatch) -> None:
    exp = _realistic("panda-4points")
    sensor = exp.sensor.sensor
    dots = pnp.set_dots

    def two_lost(*args: Any) -> Any:
        out = dots(*args)
        out[:2] = np.nan  # two dots of the set not detected this frame
        return out

    sensor.reset()
    bMc = exp.robot.kinematics(exp.q0, check_limits=False)[0]
    assert sensor.read(exp.task, exp.scene, bMc, 0.0).no_pose is None
    monkeypatch.setattr(pnp, "set_dots", two_lost)
    miss = sensor.read(exp.task, exp.scene, bMc, 0.04).no_pose
    assert miss == NoPose(1, "target", 2, 4)
    assert "2 detected dot(s) of its 4, at least 4 needed" in no_pose_event(miss).message


def test_no_pose_reaches_the_log_the_summary_and_the_campaign_counts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A reactive law (``wln``: no PnP of its own) through the realistic preset: the frames
    without a pose are flagged at the steps that use them, value the frames in a row."""
    defn = load_campaign("mc05-joint-limits")
    over = [*camera_overrides("realistic"), "simulation.max_iterations=10"]
    defn = replace(defn, scenario=apply_overrides(defn.scenario, over))
    exp = build(draw_sample(defn, 0, 0).scenario)  # its start's own solves done
    calls = _failing(monkeypatch)
    result = exp.run(method="wln")
    assert calls[0] >= 8 and len(result.log) == 10
    column = result.log.flag(Flag.NO_POSE)
    raised = column[np.isfinite(column)]
    assert raised.size >= 3 and np.nanmax(column) == 3.0  # frames 3, 4, 5 in a row
    assert np.all(np.diff(np.flatnonzero(np.isfinite(column))) == 1)  # one stretch
    assert result.summary.flags["no-pose"].count == raised.size
    _failing(monkeypatch, lambda k: k % 2 == 0)  # every second solve, build's included
    kw = {"methods": ["wln"], "samples": 1, "seed": 0, "workers": 1, "progress": False}
    (row,) = run_campaign(defn, out=tmp_path / "c", **kw).rows
    assert "no-pose" in str(row["flags"]).split(";")
    assert "no-pose" in (tmp_path / "c" / "campaign.md").read_text(encoding="utf-8")
