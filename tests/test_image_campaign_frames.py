"""An image campaign through the realistic camera gives the same rows with the compiled
frames (the exposure of redservo.kernels.blob_expose, the tracker's frame of
redservo.kernels.blob_frame) as with the layer-by-layer and dot-by-dot code they replace."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from redservo.kernels._jit import COMPILED

pytest.importorskip("cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'")

from redservo.campaign import load_campaign, run_campaign
from redservo.experiment.camera_presets import camera_overrides
from redservo.scenario import apply_overrides
from redservo.vision import motion_blur, tracking


@pytest.mark.skipif(not COMPILED, reason="the compiled frames need numba")
def test_realistic_campaign_rows_are_the_same_with_the_compiled_frames(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    defn = load_campaign("panda-near-limits")
    defn = replace(defn, scenario=apply_overrides(defn.scenario, camera_overrides("realistic")))
    used = {"exposure": 0, "tracker": 0}
    exposure, tracker = motion_blur._dot_frame, tracking.track_tracked

    def counted_exposure(*args: object) -> object:
        out = exposure(*args)  # type: ignore[arg-type]
        used["exposure"] += out is not None
        return out

    def counted_tracker(*args: object) -> object:
        out = tracker(*args)  # type: ignore[arg-type]
        used["tracker"] += out is not None
        return out

    kw = {"methods": ["wln"], "samples": 2, "seed": 0, "workers": 1, "progress": False}
    monkeypatch.setattr(motion_blur, "_dot_frame", counted_exposure)
    monkeypatch.setattr(tracking, "track_tracked", counted_tracker)
    fast = [dict(r) for r in run_campaign(defn, out=tmp_path / "fast", **kw).rows]
    monkeypatch.setattr(motion_blur, "_dot_frame", lambda *a: None)
    monkeypatch.setattr(tracking, "track_tracked", lambda *a: None)
    ref = [dict(r) for r in run_campaign(defn, out=tmp_path / "ref", **kw).rows]
    assert used["exposure"] > 300 and used["tracker"] > 300, used
    assert [r["outcome"] for r in fast] == [r["outcome"] for r in ref]
    assert repr(fast) == repr(ref)  # every logged number, NaN fields by their text
