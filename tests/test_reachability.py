"""Reachability of a campaign sample's goal (redservo.campaign.reach) and the success rate
among reachable samples in the campaign statistics."""

from __future__ import annotations

import numpy as np

from redservo.campaign.reach import desired_camera_pose, reachable, solve_ik
from redservo.campaign.stats import method_stats, stats_table, wilson_interval
from redservo.campaign.table import RunTable
from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario
from redservo.spatial import inverse, matrix_to_rotvec


def test_ik_reaches_the_pose_within_the_bounds() -> None:
    """From the nominal start of panda-4points: the IK's q lies within the bounds and puts the
    camera on the desired pose (position 0.1 mm, orientation 1 mrad); the goal is reachable."""
    exp = build(load_scenario("panda-4points"))
    T = desired_camera_pose(exp)
    assert T is not None
    lim = exp.limits
    span = lim.q_max - lim.q_min
    lo, hi = lim.q_min + 0.01 * span, lim.q_max - 0.01 * span
    q = None
    for seed in (exp.q0, 0.5 * (lo + hi)):
        q = q if q is not None else solve_ik(exp.robot, T, seed, lo, hi)
    assert q is not None and np.all(q >= lo) and np.all(q <= hi)
    cMt = inverse(exp.robot.fkine(q, check_limits=False)) @ T
    assert (
        np.linalg.norm(cMt[:3, 3]) < 1e-4 and np.linalg.norm(matrix_to_rotvec(cMt[:3, :3])) < 1e-3
    )
    assert reachable(exp) is True


def test_a_goal_out_of_reach_is_unreachable() -> None:
    """The target 3 m away (the Panda reaches ~0.85 m): unreachable; a task given by feature
    values (no desired pose) is unknown (None)."""
    sc = apply_overrides(
        load_scenario("panda-4points"), ["task.desired_pose.translation=[0, 0, 3.0]"]
    )
    assert reachable(build(sc)) is False
    gaze = build(load_scenario("cm01-gaze"))
    if gaze.scenario.spec.task.desired_pose is None:
        assert reachable(gaze) is None


def _rows() -> list[dict[str, object]]:
    rows = []
    for i in range(10):  # samples 0-5 reachable; the method succeeds on 0-3 and on 7
        rows.append(
            {
                "sample": i, "method": "m", "attempts": 0, "outcome": "converged",
                "success": i < 4 or i == 7, "reachable": str(i < 6), "iterations": 10,
                "max_joint_speed": 1.0, "max_cam_translation": 0.1, "max_cam_rotation": 0.1,
                "discontinuity": 0.0, "min_margin": 0.05, "final_error": 1e-4,
                "peak_velocity_ratio": 0.5, "flags": "",
            }
        )  # fmt: skip
    return rows


def test_success_among_reachable_samples_with_wilson_intervals() -> None:
    """Overall 5/10; among the 6 reachable samples 4/6 with the Wilson interval of 4/6, the
    same from the rows and from the run table, and printed in the markdown table."""
    rows = _rows()
    s = method_stats("m", rows)
    assert (s.successes, s.runs) == (5, 10)
    assert (s.reachable_successes, s.reachable_runs) == (4, 6)
    assert (s.reach_ci_low, s.reach_ci_high) == wilson_interval(4, 6)
    table = RunTable(["m"], 10)
    for r in rows:
        table.add(r)
    assert table.stats("m") == s
    assert "4/6 = 66.7 %" in stats_table([s])
    unknown = method_stats("m", [{**r, "reachable": ""} for r in rows])
    assert unknown.reachable_runs == -1 and "| — |" in stats_table([unknown])
