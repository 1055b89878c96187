"""Camera distortion (OpenCV's radial-tangential model) and intrinsics files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from redservo.calibration.files import load_camera, save_camera
from redservo.camera import Camera
from redservo.errors import ConfigurationError

cv2 = pytest.importorskip("cv2")

CAM = Camera(
    px=610.0, py=605.0, u0=322.5, v0=238.0, k1=-0.21, k2=0.09, p1=0.0012, p2=-0.0008, k3=-0.02
)


def _K(cam: Camera) -> np.ndarray:
    return np.array([[cam.px, 0, cam.u0 - 0.5], [0, cam.py, cam.v0 - 0.5], [0, 0, 1.0]])


def _points(n: int = 200, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    xy = rng.uniform([-0.5, -0.38], [0.5, 0.38], (n, 2))
    return np.column_stack([xy, np.ones(n)]) * rng.uniform(0.3, 2.0, (n, 1))


def test_pixels_match_cv2_project_points() -> None:
    P = _points()
    uv_cv, _ = cv2.projectPoints(P, np.zeros(3), np.zeros(3), _K(CAM), np.array(CAM.distortion))
    uv = CAM.normalized_to_pixel(CAM.project(P))
    # OpenCV's pixel centres are on the integers, redservo's on the half-integers.
    np.testing.assert_allclose(uv, uv_cv[:, 0, :] + 0.5, atol=1e-9)


def test_undistort_matches_cv2_and_inverts_distort() -> None:
    xy = CAM.project(_points())
    uv = CAM.normalized_to_pixel(xy)
    np.testing.assert_allclose(CAM.pixel_to_normalized(uv), xy, atol=1e-13)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    src = (uv - 0.5)[:, None, :]
    und = cv2.undistortPoints(src, _K(CAM), np.array(CAM.distortion), None, None, None, crit)
    np.testing.assert_allclose(CAM.pixel_to_normalized(uv), und[:, 0, :], atol=1e-9)


def test_distort_jacobian_by_finite_differences() -> None:
    from redservo.camera import _distort

    xy = CAM.project(_points(20))
    _, J = _distort(xy, CAM.distortion)
    h = 1e-7
    for j in range(2):
        dp = np.zeros(2)
        dp[j] = h
        fd = (_distort(xy + dp, CAM.distortion)[0] - _distort(xy - dp, CAM.distortion)[0]) / (2 * h)
        np.testing.assert_allclose(J[:, :, j], fd, atol=1e-7)


def test_no_distortion_is_the_pinhole() -> None:
    cam = Camera()
    assert not cam.distorted
    xy = np.array([[0.1, -0.2]])
    np.testing.assert_array_equal(cam.normalized_to_pixel(xy), [[380.0, 120.0]])


def test_bad_coefficient() -> None:
    with pytest.raises(ConfigurationError, match="k3"):
        Camera(k3=float("nan"))


# -- files -------------------------------------------------------------------------------------

ROS1 = """image_width: 640
image_height: 480
camera_name: cam
camera_matrix:
  rows: 3
  cols: 3
  data: [610.0, 0.0, 322.0, 0.0, 605.0, 237.5, 0.0, 0.0, 1.0]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.21, 0.09, 0.0012, -0.0008, -0.02]
"""

FLAT = """header:
  frame_id: camera
height: 480
width: 640
distortion_model: plumb_bob
D: [-0.21, 0.09, 0.0012, -0.0008, -0.02]
K: [610.0, 0.0, 322.0, 0.0, 605.0, 237.5, 0.0, 0.0, 1.0]
"""


@pytest.mark.parametrize("suffix", [".yaml", ".xml", ".json"])
def test_opencv_file_round_trip(tmp_path: Path, suffix: str) -> None:
    path = save_camera(tmp_path / f"cam{suffix}", CAM, rms_px=0.1)
    assert load_camera(path) == CAM


@pytest.mark.parametrize(
    "text", [ROS1, FLAT, FLAT.replace("D:", "d:").replace("K:", "k:")], ids=["ros1", "flat", "ros2"]
)
def test_ros_camera_info(tmp_path: Path, text: str) -> None:
    path = tmp_path / "info.yaml"
    path.write_text(text)
    assert load_camera(path) == CAM


def test_opencv_reads_our_file(tmp_path: Path) -> None:
    path = save_camera(tmp_path / "cam.yaml", CAM)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    np.testing.assert_allclose(fs.getNode("camera_matrix").mat(), _K(CAM))
    np.testing.assert_allclose(fs.getNode("distortion_coefficients").mat().ravel(), CAM.distortion)


@pytest.mark.parametrize(
    ("text", "key"),
    [
        (FLAT.replace("K:", "Kx:"), "camera_matrix"),
        (FLAT.replace("0.0, 0.0, 1.0]", "0.0, 1.0]"), "K"),
        (FLAT.replace("plumb_bob", "equidistant"), "distortion_model"),
        (FLAT.replace("D: [", "D: [0.3, 0.1, 0.2, "), "D"),
        (FLAT.replace("width: 640", "width: -3"), "width"),
        (FLAT.replace("605.0", "-605.0"), "K"),
    ],
)
def test_bad_file_names_file_and_key(tmp_path: Path, text: str, key: str) -> None:
    path = tmp_path / "info.yaml"
    path.write_text(text)
    with pytest.raises(ConfigurationError) as info:
        load_camera(path)
    assert str(path) in str(info.value) and f"'{key}'" in str(info.value)


def test_unreadable_file(tmp_path: Path) -> None:
    path = tmp_path / "x.yaml"
    path.write_text("camera_matrix: [1, 2\n  ]]] :::\n")
    with pytest.raises(ConfigurationError, match=r"x\.yaml"):
        load_camera(path)
    with pytest.raises(ConfigurationError, match="no such camera file"):
        load_camera(tmp_path / "missing.yaml")


# -- scenarios ---------------------------------------------------------------------------------


def _scenario(tmp_path: Path, camera: dict, sensor: dict | None = None) -> object:
    from redservo.scenario import load_scenario, parse_scenario

    data = load_scenario("panda-4points").data
    data["camera"] = camera
    if sensor is not None:
        data["sensor"] = sensor
    return parse_scenario(data, str(tmp_path / "s.toml"), base_dir=tmp_path)


def test_scenario_camera_file_relative_to_the_scenario(tmp_path: Path) -> None:
    from redservo.experiment.build import build

    (tmp_path / "calib").mkdir()
    save_camera(tmp_path / "calib" / "cam.yaml", CAM)
    exp = build(_scenario(tmp_path, {"file": "calib/cam.yaml"}))  # type: ignore[arg-type]
    assert exp.camera == CAM


def test_scenario_distortion_key(tmp_path: Path) -> None:
    from redservo.experiment.build import build

    exp = build(_scenario(tmp_path, {"distortion": [-0.1, 0.02, 0.0, 0.001]}))  # type: ignore[arg-type]
    assert exp.camera.distortion == (-0.1, 0.02, 0.0, 0.001, 0.0)


@pytest.mark.parametrize(
    ("camera", "sensor", "key"),
    [
        ({"file": "missing.yaml"}, None, "camera.file"),
        ({"file": "bad.yaml"}, None, "camera.file"),
        ({"file": "cam.yaml", "px": 500.0}, None, "camera.px"),
        ({"distortion": [0.1, 0.2]}, None, "camera.distortion"),
        ({"distortion": [0.1, 0.0, 0.0, 0.0]}, {"distortion": 0.1}, "sensor.distortion"),
    ],
)
def test_bad_scenario_camera(tmp_path: Path, camera: dict, sensor: dict | None, key: str) -> None:
    from redservo.errors import ScenarioError
    from redservo.experiment.build import build

    save_camera(tmp_path / "cam.yaml", CAM)
    (tmp_path / "bad.yaml").write_text(FLAT.replace("K:", "Q:"))
    with pytest.raises(ScenarioError) as info:
        build(_scenario(tmp_path, camera, sensor))  # type: ignore[arg-type]
    assert f"key '{key}'" in str(info.value) and "s.toml" in str(info.value)


def test_image_sensor_undistorts_the_dots() -> None:
    """Through a distorted lens, the detected points equal the true (undistorted) ones."""
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    sc = apply_overrides(load_scenario("panda-eye-to-hand"), ['sensor.kind="image"'])
    exp = build(sc)
    assert exp.camera.distorted and exp.sensor is not None
    bMc = exp.robot.fkine(exp.q0)
    exp.sensor.reset()
    exp.sensor.read(exp.task, exp.scene, bMc, 0.0)  # first frame: trackers start
    reading = exp.sensor.read(exp.task, exp.scene, bMc, 0.0)
    s_true, _ = exp.task.measure(exp.scene, bMc, 0.0)
    assert reading.s is not None
    # 0.05 px at 600 px per unit; without undistortion the error is 0.5 px here.
    assert np.abs(reading.s - s_true).max() < 0.05 / 600
    raw = exp.camera.distort(reading.s.reshape(-1, 2)).ravel()
    assert np.abs(raw - s_true).max() > 0.3 / 600
