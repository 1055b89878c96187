"""Motion blur of an exposure (redservo.vision.motion_blur): a dot seen by a moving camera is
smeared along its image motion, centred on the middle of the exposure, with its light kept."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.scene import PointSet, Scene, Static
from redservo.spatial import make_transform

cv2 = pytest.importorskip("cv2", reason="the renderer needs OpenCV (redservo[vision])")

from redservo.vision.motion_blur import exposed_image  # noqa: E402
from redservo.vision.render import Renderer  # noqa: E402


def _camera_at(x: float) -> np.ndarray:
    return make_transform(t=[x, 0.0, 0.0])


def test_a_moving_camera_smears_the_dot_along_its_motion() -> None:
    scene = Scene(
        [PointSet("p", [[0.0, 0.0, 0.0]], trajectory=Static(make_transform(t=[0, 0, 1])))]
    )
    renderer = Renderer()
    still = renderer.render(scene, _camera_at(0.0)).astype(float)
    # The camera moves 3 cm along x during the exposure: 18 px at f = 600 px, 1 m away.
    samples = [(_camera_at(x), 0.0) for x in np.linspace(-0.015, 0.015, 5)]
    blurred = exposed_image(renderer, scene, samples).astype(float)
    bg = float(np.median(still))
    light_still, light_blur = still - bg, blurred - bg
    cols_still = np.flatnonzero(light_still.max(axis=0) > 20)
    cols_blur = np.flatnonzero(light_blur.max(axis=0) > 20)
    rows_blur = np.flatnonzero(light_blur.max(axis=1) > 20)
    assert cols_blur.size > cols_still.size + 12  # a horizontal streak ...
    assert rows_blur.size <= np.flatnonzero(light_still.max(axis=1) > 20).size + 1  # ... only
    assert light_blur.sum() == pytest.approx(light_still.sum(), rel=0.02)  # the light is kept
    u = np.arange(still.shape[1])
    centroid = (light_blur.clip(0).sum(axis=0) * u).sum() / light_blur.clip(0).sum()
    centroid_still = (light_still.clip(0).sum(axis=0) * u).sum() / light_still.clip(0).sum()
    assert centroid == pytest.approx(centroid_still, abs=0.2)  # centred on mid-exposure
