"""ImageSensor: at σ = 0 it agrees with IdealSensor for every feature kind; losses are reported."""

from __future__ import annotations

import re

import numpy as np
import pytest

from redservo.errors import ConfigurationError
from redservo.features import (
    CylinderFeature,
    LineFeature,
    MomentFeatures,
    PointFeature,
    SphereFeature,
)
from redservo.scene import ConstantVelocity, Cylinder, Line, PointSet, Scene, Sphere, Static
from redservo.sensors import IdealSensor, Sensor
from redservo.spatial import make_transform, rotvec_to_matrix
from redservo.task import TaskTerm, VisualTask

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.vision import FEATURE_LOST, ImageSensor  # noqa: E402
from redservo.vision.tracking import LOSS_REASONS  # noqa: E402

PX = 600.0
DOTS = np.array(
    [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]
)
EYE = np.eye(4)


def _pose(rv: list[float], t: list[float]) -> np.ndarray:
    return make_transform(rotvec_to_matrix(rv), t)


def _scene() -> Scene:
    return Scene(
        [
            PointSet(
                "target", DOTS, trajectory=Static(_pose([0.1, -0.2, 0.3], [0.02, -0.03, 0.9]))
            ),
            Sphere("ball", 0.05, trajectory=Static(make_transform(t=[-0.2, 0.1, 1.0]))),
            Cylinder(
                "cyl", 0.03, (0, 1, 0.2), trajectory=Static(_pose([0, 0, 0.2], [0.25, 0, 1.2]))
            ),
            Line("ln", (0, 0, 0), (1, 0.1, 0), trajectory=Static(make_transform(t=[0, 0.25, 1.0]))),
        ]
    )


DESIRED = {
    "target": make_transform(t=[0, 0, 0.6]),
    "ball": make_transform(t=[0, 0, 0.7]),
    "cyl": make_transform(t=[0, 0, 0.7]),
    "ln": make_transform(t=[0, 0.1, 0.8]),
}

# Tolerances at σ = 0 (normalized units; 1 px = 1/600): point 0.05 px; moments' xn, yn
# 0.1 px x an, an 1e-3 relative, α 2 mrad, the rotation invariants 1 % relative; sphere
# centre 0.05 px, area and n_ij 0.5 % relative; cylinder and line ρ 0.05 px and 0.1 px,
# θ 0.5 mrad.
CASES = {
    "point": ([TaskTerm(PointFeature(p), "target") for p in DOTS], [0.05 / PX] * 8),
    "moments": (
        [TaskTerm(MomentFeatures.at_desired_pose(DOTS, DESIRED["target"]), "target")],
        ["xn", "yn", "an", "alpha", "r1", "r2"],
    ),
    "sphere": ([TaskTerm(SphereFeature(0.05), "ball")], [0.05 / PX, 0.05 / PX, "rel5e-3"]),
    "sphere-moments": (
        [TaskTerm(SphereFeature(0.05, variant="moments"), "ball")],
        [0.05 / PX, 0.05 / PX, "rel5e-3", "n", "rel5e-3"],
    ),
    "sphere-paper": (
        [TaskTerm(SphereFeature(0.05, variant="paper"), "ball")],
        [0.05 / PX] * 2 + ["rel5e-3"],
    ),
    "cylinder": ([TaskTerm(CylinderFeature(0.03, (0, 1, 0.2)), "cyl")], [0.05 / PX, 5e-4] * 2),
    "line": ([TaskTerm(LineFeature((0, 0, 0), (1, 0.1, 0)), "ln")], [0.1 / PX, 5e-4]),
}


def _check(kind: str, got: np.ndarray, want: np.ndarray, tols: list) -> None:
    for j, tol in enumerate(tols):
        if tol == "rel5e-3":
            assert got[j] == pytest.approx(want[j], rel=5e-3), (kind, j)
        elif tol == "n":  # n11 of the sphere: 0.5 % of the largest moment
            assert abs(got[j] - want[j]) <= 5e-3 * max(want[2], want[4]), (kind, j)
        elif tol in ("xn", "yn"):
            assert abs(got[j] - want[j]) <= 0.1 / PX * want[2], (kind, j)
        elif tol == "an":
            assert got[j] == pytest.approx(want[j], rel=1e-3), (kind, j)
        elif tol == "alpha":
            assert abs(got[j] - want[j]) <= 2e-3, (kind, j)
        elif tol in ("r1", "r2"):
            assert got[j] == pytest.approx(want[j], rel=1e-2), (kind, j)
        else:
            assert abs(got[j] - want[j]) <= tol, (kind, j, got[j] - want[j])


@pytest.mark.parametrize("kind", sorted(CASES))
@pytest.mark.parametrize("distortion", [0.0, -0.2])
def test_image_and_ideal_sensors_agree_at_zero_noise(kind: str, distortion: float) -> None:
    terms, tols = CASES[kind]
    task = VisualTask.from_desired_poses(terms, DESIRED)
    scene = _scene()
    ideal = IdealSensor().read(task, scene, EYE, 0.0)
    sensor = ImageSensor(distortion=distortion, depth="true")
    assert isinstance(sensor, Sensor)
    got = sensor.read(task, scene, EYE, 0.0)
    assert got.s is not None and ideal.s is not None, got.reason
    assert got.lost == () and got.reason == ""
    _check(kind, got.s, ideal.s, tols)
    for a, b in zip(got.inv_depth, ideal.inv_depth):
        assert np.array_equal(a, b)
    image = np.asarray(got.image)  # an array, or a LazyFrame of the dots' windows
    assert image.dtype == np.uint8 and image.shape == (480, 640)


def test_depth_policies() -> None:
    terms = [
        TaskTerm(SphereFeature(0.05), "ball"),
        TaskTerm(CylinderFeature(0.03, (0, 1, 0.2)), "cyl"),
        TaskTerm(PointFeature(DOTS[0]), "target"),
    ]
    task = VisualTask.from_desired_poses(terms, DESIRED)
    scene = _scene()
    true_d = IdealSensor().read(task, scene, EYE, 0.0).inv_depth
    desired = ImageSensor().read(task, scene, EYE, 0.0)
    assert task.inv_depth_star is not None
    assert all(np.array_equal(a, b) for a, b in zip(desired.inv_depth, task.inv_depth_star))
    est = ImageSensor(depth="estimated").read(task, scene, EYE, 0.0).inv_depth
    assert est[0] == pytest.approx(true_d[0], rel=5e-3)  # sphere: exact up to detection
    assert est[1] == pytest.approx(true_d[1], rel=5e-3)  # cylinder: exact up to detection
    assert est[2][0] == pytest.approx(true_d[2][0], rel=0.05)  # tilted dots: a mean depth
    with pytest.raises(ConfigurationError, match="no known size"):
        ImageSensor(depth="estimated").read(
            VisualTask.from_desired_poses(CASES["line"][0], DESIRED), scene, EYE, 0.0
        )
    with pytest.raises(ConfigurationError, match="depth must be"):
        ImageSensor(depth="guess")  # type: ignore[arg-type]


def test_tracking_along_a_motion_matches_the_ideal_features() -> None:
    # The dots and the sphere drift across the image while the camera moves.
    traj = ConstantVelocity(
        _pose([0.1, -0.2, 0.3], [-0.1, -0.03, 0.9]), v=[0.1, 0.02, 0.0], w=[0, 0, 0.5]
    )
    scene = Scene(
        [
            PointSet("target", DOTS, trajectory=traj),
            Sphere(
                "ball",
                0.05,
                trajectory=ConstantVelocity(make_transform(t=[-0.2, 0.22, 1.0]), v=[0.05, 0, 0]),
            ),
        ]
    )
    terms = [TaskTerm(PointFeature(p), "target") for p in DOTS]
    terms.append(TaskTerm(SphereFeature(0.05, variant="moments"), "ball"))
    task = VisualTask.from_desired_poses(terms, DESIRED)
    sensor = ImageSensor(noise_px=0.5, blur_px=0.5, seed=4)
    for k in range(25):
        t = 0.1 * k
        bMc = make_transform(t=[0.0, 0.004 * k, 0.0])
        got = sensor.read(task, scene, bMc, t)
        ideal = IdealSensor().read(task, scene, bMc, t)
        assert got.s is not None and ideal.s is not None and got.lost == ()
        assert np.abs(got.s[:8] - ideal.s[:8]).max() * PX < 0.1  # never swapped
        assert np.abs(got.s[8:10] - ideal.s[8:10]).max() * PX < 0.1
    sensor.reset()
    again = sensor.read(task, scene, EYE, 0.0)
    first = ImageSensor(noise_px=0.5, blur_px=0.5, seed=4).read(task, scene, EYE, 0.0)
    assert again.s is not None and first.s is not None
    assert np.array_equal(again.image, first.image) and np.array_equal(again.s, first.s)


def test_an_occluded_dot_is_lost_then_feature_lost() -> None:
    # A sphere moves in front of the dots (MC05's occluder): dots vanish one by one.
    scene = Scene(
        [
            PointSet("target", DOTS, trajectory=Static(make_transform(t=[0.0, 0.0, 0.8]))),
            Sphere(
                "occ",
                0.03,
                trajectory=ConstantVelocity(make_transform(t=[0.25, -0.0, 0.5]), v=[-0.1, 0, 0]),
            ),
        ]
    )
    task = VisualTask.from_desired_poses(
        [TaskTerm(MomentFeatures.at_desired_pose(DOTS, DESIRED["target"]), "target")], DESIRED
    )
    sensor = ImageSensor(max_lost_frames=2)
    seen_lost = False
    for k in range(40):
        got = sensor.read(task, scene, EYE, 0.1 * k)
        if got.s is None:
            assert got.reason.startswith(FEATURE_LOST) and "2 consecutive" in got.reason
            assert sensor.feature_lost and got.lost == (0,)
            break
        if got.lost:
            seen_lost = True
            assert "dot blob(s), expected 4" in got.reason and "predicted" in got.reason
            why = re.search(r"dot\(s\) \d+ \((\w+)\)", got.reason)  # each lost dot, with why
            assert why is not None and why.group(1) in LOSS_REASONS, got.reason
    else:
        pytest.fail("the occluded dots were never reported lost")
    assert seen_lost


def test_extra_blobs_are_reported_but_tracking_goes_on() -> None:
    other = PointSet(
        "other", [[0.0, 0.0, 0.0]], trajectory=Static(make_transform(t=[-0.3, 0.25, 1.0]))
    )
    base = _scene()
    scene = Scene([base.object(n) for n in base.names] + [other])
    task = VisualTask.from_desired_poses(CASES["point"][0], DESIRED)
    got = ImageSensor().read(task, scene, EYE, 0.0)
    assert got.s is not None and got.lost == ()
    assert "found 5 dot blob(s), expected 4" in got.reason


def test_features_not_visible_at_start_are_lost() -> None:
    scene = Scene([Sphere("ball", 0.05, trajectory=Static(make_transform(t=[0, 0, -1.0])))])
    task = VisualTask.from_desired_poses([TaskTerm(SphereFeature(0.05), "ball")], DESIRED)
    got = ImageSensor().read(task, scene, EYE, 0.0)
    assert got.s is None and got.reason.startswith(FEATURE_LOST) and got.lost == (0,)


def test_from_config() -> None:
    sensor = ImageSensor.from_config(
        None,
        {
            "kind": "image",
            "noise_px": 1.0,
            "blur_px": 0.5,
            "distortion": [-0.1, 0.01],
            "seed": 2,
            "depth": "estimated",
            "max_lost_frames": 5,
            "texture": True,
        },
    )
    opt = sensor.renderer.options
    assert (opt.noise_px, opt.blur_px, opt.k1, opt.k2, opt.seed, opt.texture) == (
        1.0,
        0.5,
        -0.1,
        0.01,
        2,
        True,
    )
    assert sensor.depth == "estimated" and sensor.max_lost_frames == 5
    with pytest.raises(ConfigurationError, match=r"unknown \[sensor\] key.*allowed"):
        ImageSensor.from_config(None, {"kind": "image", "noise": 1.0})
    with pytest.raises(ConfigurationError, match="max_lost_frames"):
        ImageSensor.from_config(None, {"max_lost_frames": -1})
    with pytest.raises(ConfigurationError, match="distortion"):
        ImageSensor.from_config(None, {"distortion": [0.1, 0.2, 0.3]})


def test_in_the_loop_like_the_ideal_sensor() -> None:
    # The shipped gazing scenario through the simulator, features measured in the image.
    from redservo.experiment.build import build
    from redservo.scenario import apply_overrides, load_scenario

    base = load_scenario("cm01-gaze")
    image = apply_overrides(
        base, ['sensor.kind="image"', 'sensor.depth="true"', "sensor.noise_px=0.5"]
    )
    got, ideal = build(image).run(), build(base).run()
    assert got.outcome == ideal.outcome == "converged"
    n_got, n_ideal = got.summary.to_dict()["iterations"], ideal.summary.to_dict()["iterations"]
    assert abs(n_got - n_ideal) <= 5


def test_dots_tracked_under_a_lighting_gradient() -> None:
    # ±15 % of light per axis (reproduce --sensor image): the dots sit in the dim corner, at
    # about 0.8 of their level (below the known-levels threshold), the sphere in the bright
    # one, above it (speckles the size of a dot). Each dot keeps its own gray levels.
    from redservo.reproduction.imaging import Imaging, image_sensor

    dots = np.array([[-0.04, -0.03, 0.0], [0.04, -0.03, 0.0], [0.04, 0.03, 0.0], [-0.03, 0.03, 0]])
    scene = Scene(
        [
            PointSet(
                "target",
                dots,
                trajectory=ConstantVelocity(make_transform(t=[-0.56, -0.4, 1.5]), v=[-0.1, 0, 0]),
            ),
            Sphere("ball", 0.12, trajectory=Static(make_transform(t=[0.5, 0.38, 1.2]))),
        ]
    )
    terms = [TaskTerm(PointFeature(p), "target") for p in dots]
    task = VisualTask.from_desired_poses(terms, {"target": make_transform(t=[0, 0, 1.0])})
    lit = Imaging(noise_px=4.0, blur_px=0.8, gradient=0.15)
    sensor = image_sensor(ImageSensor().camera, lit, seed=1)
    for k in range(8):
        got = sensor.read(task, scene, EYE, 0.1 * k)
        ideal = IdealSensor().read(task, scene, EYE, 0.1 * k)
        assert got.s is not None and ideal.s is not None
        assert got.lost == () and got.reason == "", got.reason  # the blob count is right too
        assert np.abs(got.s - ideal.s).max() * PX < 0.15
    u, v = sensor.dots_uv[0].astype(int)  # the dots are dimmer than the known-levels threshold
    assert got.image is not None and got.image[v - 4 : v + 5, u - 4 : u + 5].max() < 200


def test_sphere_measured_under_a_lighting_gradient() -> None:
    # A sphere in the dim corner of a ±15 % gradient is darker than its fixed threshold
    # (midway to the cylinder's level): the threshold follows the light measured at its centre.
    from redservo.reproduction.imaging import Imaging, image_sensor

    ball = Sphere("ball", 0.03, trajectory=Static(make_transform(t=[-0.43, -0.32, 1.0])))
    task = VisualTask.from_desired_poses([TaskTerm(SphereFeature(0.03), "ball")], DESIRED)
    scene = Scene([ball])
    lit = Imaging(noise_px=4.0, blur_px=0.8, gradient=0.15)
    sensor = image_sensor(ImageSensor().camera, lit, seed=1)
    ideal = IdealSensor().read(task, scene, EYE, 0.0)
    for _ in range(3):
        got = sensor.read(task, scene, EYE, 0.0)
        assert got.s is not None and ideal.s is not None and got.lost == (), got.reason
        # the light's slope pulls the intensity-weighted centre 0.14 px toward the bright side
        assert np.abs(got.s[:2] - ideal.s[:2]).max() * PX < 0.3
        assert got.s[2] == pytest.approx(ideal.s[2], rel=2e-2)
    u, v = (int(c) for c in sensor.renderer.optics.to_pixel(ideal.s[:2]))
    assert got.image is not None and np.median(got.image[v - 3 : v + 4, u - 3 : u + 4]) < 135
