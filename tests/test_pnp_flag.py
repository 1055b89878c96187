"""A frame whose tracked dots give no PnP pose is the typed flag ``no-pose``: in the
``predictive`` step's diagnostics, the run's log and summary, and the campaign's flag counts
(not only a counter on the law and a line of ``info``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("cv2", reason="PnP needs OpenCV: pip install 'redservo[vision]'")

from redservo.campaign import load_campaign, run_campaign
from redservo.experiment.build import build
from redservo.experiment.camera_presets import camera_overrides
from redservo.kernels import flagbits as fb
from redservo.redundancy import LawResult
from redservo.redundancy.base import Diagnostics
from redservo.redundancy.flags import Flag
from redservo.redundancy.predictive_pnp import DotPoses
from redservo.scenario import apply_overrides, load_scenario
from redservo.spatial import inverse


def _collinear(dots: np.ndarray) -> np.ndarray:
    """Four dots evenly spaced on the segment from the first to the third: collinear, in an
    order no pose of the target explains (its points are not collinear)."""
    d = np.asarray(dots, dtype=float)
    return d[0] + np.outer(np.linspace(0.0, 1.0, len(d)), d[2] - d[0])


def _bare() -> LawResult:
    return LawResult(np.zeros(6), Diagnostics(method="predictive", task_rank=6))


def test_collinear_or_missing_dots_flag_no_pose_with_the_frames_in_a_row() -> None:
    exp = build(load_scenario("mc05-joint-limits"))
    feature, q = exp.task.terms[0].feature, exp.q0
    cMo = inverse(exp.scene.wMb @ exp.robot.kinematics(q)[0]) @ exp.scene.wMo("target", 0.0)
    P = feature.points_o @ cMo[:3, :3].T + cMo[:3, 3]
    dots = P[:, :2] / P[:, 2:]
    poses = DotPoses()

    def step(frame: np.ndarray) -> tuple[object, LawResult]:
        poses.frame(frame, 0.0)
        bMo = poses.target_pose(exp.robot, feature.points_o, q, 0.04, exp.camera)
        return bMo, poses.flagged(_bare())

    bMo, res = step(dots)
    assert bMo is not None and res.diagnostics.events == ()
    for k in (1, 2):
        bMo, res = step(_collinear(dots))
        (ev,) = res.diagnostics.events
        assert bMo is None and ev.flag is Flag.NO_POSE and ev.value == k
        assert "reprojection tolerance" in ev.message and "4 tracked dots" in ev.message
    missing = dots.copy()
    missing[2] = np.nan  # a dot the tracker lost
    bMo, res = step(missing)
    (ev,) = res.diagnostics.events
    assert bMo is None and ev.value == 3 and "3 finite tracked dot(s) for its 4" in ev.message
    assert poses.flagged(_bare()).diagnostics.events == ()  # consumed: one event per frame
    bMo, res = step(dots)
    assert bMo is not None and res.diagnostics.events == () and poses.in_a_row == 0
    assert poses.failures == 3 and poses.poses == 2
    assert fb.NO_POSE == fb.N_FLAGS - 1  # appended: the other flags keep their numbers


def test_no_pose_reaches_the_run_log_summary_and_campaign_counts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    frame = DotPoses.frame
    seen = {"frames": 0}

    def squashed(self: DotPoses, dots: np.ndarray, age: float) -> None:
        seen["frames"] += 1  # every second frame collinear
        frame(self, _collinear(dots) if seen["frames"] % 2 == 0 else dots, age)

    monkeypatch.setattr(DotPoses, "frame", squashed)
    defn = load_campaign("mc05-joint-limits")
    over = [*camera_overrides("realistic"), "simulation.max_iterations=6"]
    defn = replace(defn, scenario=apply_overrides(defn.scenario, over))
    kw = {"methods": ["predictive"], "samples": 1, "seed": 0, "workers": 1, "progress": False}
    (row,) = run_campaign(defn, out=tmp_path / "c", **kw).rows
    assert seen["frames"] >= 6
    assert "no-pose" in str(row["flags"]).split(";")
    assert "no-pose" in (tmp_path / "c" / "campaign.md").read_text(encoding="utf-8")

    from redservo.campaign import draw_sample

    exp = build(draw_sample(defn, 0, 0).scenario)
    result = exp.run(method="predictive")
    column = result.log.flag(Flag.NO_POSE)
    assert np.sum(np.isfinite(column)) >= 2
    assert result.summary.flags["no-pose"].count == np.sum(np.isfinite(column))
