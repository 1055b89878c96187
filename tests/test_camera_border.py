"""Through the realistic camera, a target whose dot reaches the image border has left the
image: the run ends ``target_lost`` (as on the ideal sensor), not ``feature_lost`` when the
dot tracker refuses the dot cut by the border (camera_presets.REALISTIC_IMAGE_MARGIN_PX)."""

from __future__ import annotations

from dataclasses import replace

import pytest

pytest.importorskip("cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'")

from redservo.campaign import draw_sample, load_campaign
from redservo.experiment.build import build
from redservo.experiment.camera_presets import REALISTIC_IMAGE_MARGIN_PX, camera_overrides
from redservo.scenario import apply_overrides
from redservo.schema.sensor import SensorSpec


def test_the_margin_is_a_default_dot_radius() -> None:
    assert REALISTIC_IMAGE_MARGIN_PX == SensorSpec.model_fields["dot_radius_px"].default
    assert f"simulation.image_margin_px={REALISTIC_IMAGE_MARGIN_PX!r}" in camera_overrides(
        "realistic"
    )


def test_a_dot_drifting_out_of_the_image_ends_target_lost_not_feature_lost() -> None:
    # panda-near-limits, seed 0, sample 11, qp: dot 0 drifts out at the top of the image
    # (0.2-0.7 px a frame, the tracker exact until then); ended feature_lost (at_border).
    defn = load_campaign("panda-near-limits")
    defn = replace(defn, scenario=apply_overrides(defn.scenario, camera_overrides("realistic")))
    exp = build(draw_sample(defn, 0, 11).scenario)
    result = exp.run(method="qp", max_iterations=110)
    assert result.outcome == "target_lost"
    assert exp.options.image_margin_px == REALISTIC_IMAGE_MARGIN_PX
