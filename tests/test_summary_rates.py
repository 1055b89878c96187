"""The run summary's velocity ratio is never null when velocity limits exist (issue 17)."""

from __future__ import annotations

import json

import numpy as np

from redservo.limits import JointLimits
from redservo.records import LogBuffer, summarize


def _limits(qdot_max: float | None) -> JointLimits:
    return JointLimits(-np.ones(3), np.ones(3), qdot_max=qdot_max)


def test_a_run_without_a_step_has_a_zero_velocity_ratio_when_limits_exist() -> None:
    empty = LogBuffer(None, 3, 1, 2).to_log(("a", "b", "c"), ("x",))
    assert len(empty) == 0
    summary = summarize(empty, "target_lost", _limits(2.0), None, dt=0.04)
    assert summary.peak_velocity_ratio == 0.0 and summary.velocity_violations == 0
    assert json.loads(json.dumps(summary.to_dict()))["peak_velocity_ratio"] == 0.0
    # Only limits without velocity limits give no ratio.
    assert summarize(empty, "target_lost", _limits(None), None, dt=0.04).peak_velocity_ratio is None
