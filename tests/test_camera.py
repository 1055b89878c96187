"""Tests of the pinhole camera (redservo.camera)."""

import numpy as np
import pytest

from redservo.camera import MIN_DEPTH, Camera, project_points
from redservo.errors import ConfigurationError, GeometryError, ShapeError


def test_defaults_are_vga_with_centred_principal_point() -> None:
    cam = Camera()
    assert (cam.width, cam.height) == (640, 480)
    assert (cam.px, cam.py, cam.u0, cam.v0) == (600.0, 600.0, 320.0, 240.0)


def test_pixel_normalized_round_trip_single_and_batch() -> None:
    cam = Camera(px=800.0, py=750.0, u0=310.0, v0=250.0)
    rng = np.random.default_rng(0)
    uv = rng.uniform(-100, 800, size=(20, 2))
    assert np.allclose(cam.normalized_to_pixel(cam.pixel_to_normalized(uv)), uv, atol=1e-12)
    xy = rng.normal(size=(2,))
    back = cam.pixel_to_normalized(cam.normalized_to_pixel(xy))
    assert back.shape == (2,)
    assert np.allclose(back, xy, atol=1e-14)


def test_pixel_to_normalized_values() -> None:
    cam = Camera(px=500.0, py=400.0, u0=320.0, v0=240.0)
    # u = u0 + px x, v = v0 + py y written out by hand.
    assert np.allclose(cam.pixel_to_normalized([820.0, 40.0]), [1.0, -0.5])
    assert np.allclose(cam.normalized_to_pixel([0.0, 0.0]), [320.0, 240.0])


def test_project_divides_by_depth() -> None:
    P = np.array([[0.2, -0.4, 2.0], [0.0, 0.0, 1.0], [3.0, 1.5, 0.5]])
    xy = Camera().project(P)
    assert xy.shape == (3, 2)
    assert np.allclose(xy, [[0.1, -0.2], [0.0, 0.0], [6.0, 3.0]])
    assert np.allclose(project_points([1.0, 2.0, 4.0]), [0.25, 0.5])


@pytest.mark.parametrize("z", [0.0, -1.0, MIN_DEPTH / 2])
def test_project_rejects_points_at_or_behind_camera(z: float) -> None:
    P = np.array([[0.0, 0.0, 1.0], [0.1, 0.1, z]])
    with pytest.raises(GeometryError, match=r"point 1 .*Z = "):
        project_points(P)


@pytest.mark.parametrize(
    "bad", [np.zeros((3, 2)), np.zeros((2, 2, 3)), np.array([[0.0, 0.0, np.nan]])]
)
def test_project_rejects_bad_shapes_and_nan(bad: np.ndarray) -> None:
    with pytest.raises(ShapeError):
        project_points(bad)


def test_in_image_with_margin() -> None:
    cam = Camera()
    uv = np.array([[320.0, 240.0], [0.0, 0.0], [640.0, 480.0], [-1.0, 10.0], [5.0, 5.0]])
    xy = cam.pixel_to_normalized(uv)
    assert cam.in_image(xy).tolist() == [True, True, True, False, True]
    assert cam.in_image(xy, margin_px=10).tolist() == [True, False, False, False, False]
    assert bool(cam.in_image(xy[0])) is True


@pytest.mark.parametrize(
    "kwargs",
    [
        {"px": 0.0},
        {"py": -1.0},
        {"width": 0},
        {"height": -480},
        {"px": float("nan")},
        {"u0": float("inf")},
    ],
)
def test_invalid_intrinsics_rejected(kwargs: dict[str, float]) -> None:
    with pytest.raises(ConfigurationError):
        Camera(**kwargs)  # type: ignore[arg-type]


def test_camera_is_frozen() -> None:
    cam = Camera()
    with pytest.raises(AttributeError):
        cam.px = 1.0  # type: ignore[misc]
