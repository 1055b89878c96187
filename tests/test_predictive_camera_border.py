"""The ``predictive`` law through a camera (the ``realistic`` preset): the tracker's gate
reaches the law through the camera's timing, and the image bounds of its horizon are damped
near the border (``redundancy/predictive_qp.py``, ``damped_image_bounds``)."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.campaign.definition import load_campaign
from redservo.campaign.sampling import draw_sample
from redservo.experiment.build import build
from redservo.experiment.camera_presets import camera_overrides
from redservo.redundancy.predictive_qp import CAMERA_XI, damped_image_bounds
from redservo.scenario import apply_overrides, load_scenario
from redservo.simulation.loop import _tracking_gate


def _camera_sample(index: int):  # type: ignore[no-untyped-def]
    sc = draw_sample(load_campaign("panda-near-limits"), 0, index).scenario
    return build(apply_overrides(sc, camera_overrides("realistic")))


def test_the_tracker_gate_is_seen_through_the_camera_timing() -> None:
    """The realistic preset wraps the image sensor in its timing; the gate of the wrapped
    sensor's tracker is the loop's (None on main: the predictive law planned without it)
    and the ideal sensor has none."""
    from redservo.vision.sensor import tracking_gate_px

    exp = build(apply_overrides(load_scenario("panda-4points"), camera_overrides("realistic")))
    timed = exp.sensor
    assert timed is not None
    inner = getattr(timed, "sensor", timed)
    assert inner is not timed
    gate = _tracking_gate(timed)
    assert gate is not None and gate == tracking_gate_px(inner)
    from redservo.sensors import IdealSensor

    assert _tracking_gate(IdealSensor()) is None


def test_damped_bounds_close_a_fraction_of_the_gap_per_period() -> None:
    """At period k a point keeps ``(1 - ξ)^k`` of its gap to each bound; a point on or past
    a bound keeps that bound; the bounds tighten monotonically toward the plain ones."""
    lo, hi = np.array([-0.5, -0.4]), np.array([0.5, 0.4])
    s0 = np.array([0.3, 0.45])  # y past its upper bound
    dlo, dhi = damped_image_bounds(lo, hi, s0, 4)
    assert dlo.shape == dhi.shape == (4, 2)
    k = np.arange(1, 5)
    np.testing.assert_allclose(dhi[:, 0], 0.5 - (1 - CAMERA_XI) ** k * 0.2)
    np.testing.assert_allclose(dlo[:, 0], -0.5 + (1 - CAMERA_XI) ** k * 0.8)
    np.testing.assert_allclose(dhi[:, 1], 0.4)  # already past: the plain bound
    assert np.all(np.diff(dhi[:, 0]) > 0) and np.all(np.diff(dlo[:, 0]) < 0)
    assert np.all(dlo <= s0) and np.all(dhi[:, 0] >= s0[0])


@pytest.mark.parametrize("index", [129])
def test_a_border_riding_sample_converges_through_the_camera(index: int) -> None:
    """panda-near-limits sample 129 (seed 0) through the realistic camera: ``predictive``'s
    plan rides the image border (10 px ideally); the measured points lag the true ones by up
    to 19 px at its turns and a dot reached the border: ``target_lost`` at period 30 on main.
    With the damped bounds it converges, within every limit."""
    s = _camera_sample(index).run(method="predictive").summary
    assert s.outcome == "converged" and s.success
    assert s.shield_activations == 0 and s.velocity_violations == 0
