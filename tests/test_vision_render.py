"""The renderer: what the camera sees, including objects partly outside or behind it."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from redservo.camera import Camera
from redservo.errors import ConfigurationError
from redservo.scene import Cylinder, Line, PointSet, Scene, Sphere, Static
from redservo.spatial import make_transform

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.vision.optics import Optics  # noqa: E402
from redservo.vision.render import Renderer, RenderOptions, render  # noqa: E402

BG = RenderOptions().background
LV = RenderOptions().levels


def _scene(*objects: object) -> Scene:
    return Scene(objects)  # type: ignore[arg-type]


def _at(x: float, y: float, z: float) -> Static:
    return Static(make_transform(t=[x, y, z]))


def test_import_does_not_load_opencv() -> None:
    code = "import sys, redservo.vision; print('cv2' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_empty_scene_is_the_background() -> None:
    img = render(_scene(), np.eye(4))
    assert img.shape == (480, 640) and img.dtype == np.uint8
    assert np.all(img == BG)


@pytest.mark.parametrize(
    "where",
    [
        (0.0, 0.0, -1.0),  # behind the camera
        (0.0, 0.0, 0.0),  # on the camera plane
        (5.0, 0.0, 1.0),  # far right, outside the image
    ],
)
def test_points_behind_or_outside_draw_nothing(where: tuple[float, float, float]) -> None:
    pts = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0]])
    img = render(_scene(PointSet("p", pts, trajectory=_at(*where))), np.eye(4))
    assert np.all(img == BG)


def test_point_partly_outside_is_clipped() -> None:
    # A dot centred one pixel inside the left border: only its right half is drawn.
    cam = Camera()
    x = (1.0 - cam.u0) / cam.px
    img = render(_scene(PointSet("p", [[x, 0.0, 1.0]])), np.eye(4))
    lit = np.argwhere(img > BG + 10)
    assert lit.size and lit[:, 1].min() == 0 and lit[:, 1].max() <= 6


def test_sphere_whole_partly_outside_behind_and_around() -> None:
    # In front and visible: a disc of the sphere's level.
    img = render(_scene(Sphere("s", 0.05, trajectory=_at(0.0, 0.0, 1.0))), np.eye(4))
    assert img[240, 320] == LV.sphere and img[0, 0] == BG
    # Partly outside (centre beyond the right border): the visible part touches the border.
    img = render(_scene(Sphere("s", 0.1, trajectory=_at(0.6, 0.0, 1.0))), np.eye(4))
    assert img[240, 639] == LV.sphere and img[240, 320] == BG
    # Entirely behind the camera.
    img = render(_scene(Sphere("s", 0.1, trajectory=_at(0.0, 0.0, -1.0))), np.eye(4))
    assert np.all(img == BG)
    # Straddling the camera plane, off to the side: the visible cap, as ray casting finds it.
    C, r = np.array([0.12, 0.0, 0.05]), 0.1
    img = render(_scene(Sphere("s", r, trajectory=_at(*C))), np.eye(4))
    u, v = np.meshgrid(np.arange(640) + 0.5, np.arange(480) + 0.5)
    d = np.stack([(u - 320.0) / 600.0, (v - 240.0) / 600.0, np.ones_like(u)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    cd = d @ C
    hit = (cd > 0.0) & (C @ C - cd**2 <= r * r)
    assert hit[240, 639] and not hit[240, 320]
    agree = (img == LV.sphere) == hit
    assert agree.mean() > 0.995  # all but the anti-aliased edge
    # Camera inside the sphere: the whole view.
    img = render(_scene(Sphere("s", 1.0, trajectory=_at(0.0, 0.0, 0.2))), np.eye(4))
    assert np.all(img == LV.sphere)


def test_cylinder_band_and_behind_camera() -> None:
    cyl = Cylinder("c", 0.05, (0.0, 1.0, 0.0), trajectory=_at(0.0, 0.0, 1.0))
    img = render(_scene(cyl), np.eye(4))
    half = 600.0 * 0.05 / np.sqrt(1.0 - 0.05**2)  # image half-width of the band (px)
    row = img[100]
    lit = np.flatnonzero(row >= (BG + LV.cylinder) / 2)
    assert lit.min() == pytest.approx(320 - half, abs=1.0)
    assert lit.max() + 1 == pytest.approx(320 + half, abs=1.0)
    behind = Cylinder("c", 0.05, (0.0, 1.0, 0.0), trajectory=_at(0.0, 0.0, -1.0))
    assert np.all(render(_scene(behind), np.eye(4)) == BG)


def test_line_stripe_only_where_in_front() -> None:
    # The line X = 0, Y = 0.1 along the optical axis: its points (0, 0.1, Z) image at
    # y = 0.1/Z, below the vanishing point (v = 240) for Z > 0 only.
    ln = Line("l", (0.0, 0.1, 1.0), (0.0, 0.0, 1.0))
    img = render(_scene(ln), np.eye(4))
    lit = np.argwhere(img > BG + 20)
    assert lit.size
    assert abs(np.median(lit[:, 1]) + 0.5 - 320.0) < 1.0
    assert lit[:, 0].min() >= 239 and lit[:, 0].max() == 479


def test_nearer_objects_hide_farther_ones() -> None:
    dots = PointSet("p", [[0.0, 0.0, 0.0]], trajectory=_at(0.0, 0.0, 1.0))
    occ = Sphere("o", 0.05, trajectory=_at(0.0, 0.0, 0.5))
    img = render(_scene(dots, occ), np.eye(4))
    assert img[240, 320] == LV.sphere  # the dot behind the sphere is hidden
    far = Sphere("o", 0.05, trajectory=_at(0.0, 0.0, 3.0))
    img = render(_scene(dots, far), np.eye(4))
    assert img[240, 320] == LV.point


def test_noise_and_seed() -> None:
    opt = RenderOptions(noise_px=4.0, seed=3)
    r = Renderer(options=opt)
    a, b = r.render(_scene(), np.eye(4)), r.render(_scene(), np.eye(4))
    assert not np.array_equal(a, b)  # fresh noise per frame
    assert np.std(a.astype(float)) == pytest.approx(4.0, rel=0.05)
    assert np.mean(a.astype(float)) == pytest.approx(BG, abs=0.1)
    r.reset()
    assert np.array_equal(r.render(_scene(), np.eye(4)), a)  # same seed, same images


def test_blur_spreads_a_dot_and_texture_varies_the_background() -> None:
    dots = PointSet("p", [[0.0, 0.0, 0.0]], trajectory=_at(0.0, 0.0, 1.0))
    sharp = render(_scene(dots), np.eye(4))
    soft = render(_scene(dots), np.eye(4), options=RenderOptions(blur_px=1.5))
    assert soft.max() < sharp.max()
    assert (soft > BG + 2).sum() > (sharp > BG + 2).sum()
    tex = render(_scene(), np.eye(4), options=RenderOptions(texture=True))
    assert 5.0 < np.std(tex.astype(float)) < 20.0


def test_distortion_moves_points_as_the_model_says() -> None:
    opt = RenderOptions(k1=-0.25, k2=0.05)
    optics = Optics(Camera(), opt.k1, opt.k2)
    xy = np.array([[0.3, 0.25], [-0.35, -0.2]])
    assert np.allclose(optics.undistort(optics.distort(xy)), xy, atol=1e-12)
    pts = np.hstack([xy, np.ones((2, 1))])
    img = render(_scene(PointSet("p", pts)), np.eye(4), options=opt)
    for uv in optics.to_pixel(xy):
        j, i = int(uv[0]), int(uv[1])
        assert img[i, j] == LV.point
    undist = Camera().normalized_to_pixel(xy)
    assert not np.any(img[undist[:, 1].astype(int), undist[:, 0].astype(int)] == LV.point)


def test_options_are_checked() -> None:
    with pytest.raises(ConfigurationError, match="noise_px"):
        RenderOptions(noise_px=-1.0)
    with pytest.raises(ConfigurationError, match="background"):
        RenderOptions(background=300.0)
    with pytest.raises(ConfigurationError, match="k1"):
        Optics(Camera(), k1=float("nan"))
