"""Every shipped scenario runs through images (issue: image in the loop): rendered, detected,
servoed on what was measured. The full runs and their outcomes are in docs/vision.md; here a
few iterations each, and one full run."""

from __future__ import annotations

import pytest

pytest.importorskip("cv2", reason="the image sensor needs redservo[vision] (opencv)")

from redservo.experiment.build import build
from redservo.scenario import apply_overrides, load_scenario, shipped_scenarios

IMAGE = ['sensor.kind="image"']


@pytest.mark.parametrize("name", sorted(shipped_scenarios()))
def test_every_shipped_scenario_runs_through_images(name: str) -> None:
    if name.startswith(("ur5e", "panda-urdf")):
        pytest.importorskip("pinocchio", reason="URDF scenarios need redservo[urdf]")
    sc = apply_overrides(load_scenario(name), [*IMAGE, "simulation.max_iterations=15"])
    res = build(sc).run()
    assert res.outcome in ("converged", "max_iterations"), (name, res.outcome)
    assert len(res.log) >= 1


def test_the_gaze_converges_through_images() -> None:
    res = build(apply_overrides(load_scenario("cm01-gaze"), IMAGE)).run()
    assert res.outcome == "converged"
    assert res.summary.success


def test_run_writes_a_video_of_the_camera_view(tmp_path) -> None:
    pytest.importorskip("PIL", reason="GIF writing needs Pillow (redservo[viewer])")
    from redservo.cli.entry import main

    gif = tmp_path / "run.gif"
    args = ["run", "cm01-gaze", "--set", IMAGE[0], "--set", "simulation.max_iterations=12"]
    assert main([*args, "--no-plot", "-q", "--out", str(tmp_path / "r"), "--video", str(gif)]) == 0
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames == 12
        assert im.size[0] > im.size[1]  # the camera view with the error plot beside it
