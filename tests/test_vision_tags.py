"""Fiducial tags: rendered tags are detected with their ids, corners (to sub-pixel) and poses."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.camera import Camera
from redservo.errors import ConfigurationError, GeometryError, ShapeError, UnknownNameError
from redservo.scene import Scene, Static, Tag
from redservo.spatial import make_transform
from redservo.vision.tag_families import TAG_FAMILIES, check_tag

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.vision import detect_tags  # noqa: E402
from redservo.vision.optics import Optics  # noqa: E402
from redservo.vision.render import Renderer, RenderOptions  # noqa: E402

CAM = Camera(px=300.0, py=300.0, u0=160.0, v0=120.0, width=320, height=240)
FACING = np.array([np.pi, 0.0, 0.0])  # the tag's z (out of its face) towards the camera


def _shot(
    wMo: np.ndarray, *, tag_id: int = 3, family: str = "36h11", size: float = 0.05, **opt: float
) -> tuple[np.ndarray, np.ndarray, Renderer]:
    tag = Tag("tag", size=size, tag_id=tag_id, family=family, trajectory=Static(wMo))
    r = Renderer(CAM, RenderOptions(**opt))  # type: ignore[arg-type]
    img = r.render(Scene([tag]), np.eye(4))
    P = tag.points @ wMo[:3, :3].T + wMo[:3, 3]
    return img, r.optics.to_pixel(P[:, :2] / P[:, 2:]), r


def test_families_match_opencv() -> None:
    for name, (const, bits, n) in TAG_FAMILIES.items():
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, const))
        assert (d.markerSize, d.bytesList.shape[0]) == (bits, n), name
    assert check_tag("tag36h11") == "36h11"
    assert check_tag("4x4_50") == "aruco_4x4_50"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_corners_and_pose_at_noise_2(seed: int) -> None:
    rng = np.random.default_rng(seed)
    wMo = make_transform(
        t=[rng.uniform(-0.03, 0.03), rng.uniform(-0.02, 0.02), 0.25],
        rotvec=FACING + rng.uniform(-0.4, 0.4, 3),
    )
    img, truth, _ = _shot(wMo, noise_px=2.0, blur_px=0.5, seed=seed)
    (det,) = detect_tags(img, camera=CAM, tag_size=0.05)
    assert det.id == 3
    rms = float(np.sqrt(np.mean(np.sum((det.corners - truth) ** 2, axis=1))))
    assert rms < 0.1  # corner k is the image of Tag.points[k]: the order is checked too
    assert det.cMo is not None
    assert np.linalg.norm(det.cMo[:3, 3] - wMo[:3, 3]) < 2e-3
    assert np.abs(det.cMo[:3, :3] - wMo[:3, :3]).max() < 0.03
    assert det.reprojection_px < 0.2


def test_frame_conventions() -> None:
    """ViSP's frame: z out of the face (facing tag: cRo = Rx(π)); z_aligned: cRo = I."""
    wMo = make_transform(t=[0.0, 0.0, 0.3], rotvec=FACING)
    img, _, _ = _shot(wMo)
    (det,) = detect_tags(img, camera=CAM, tag_size=0.05)
    (al,) = detect_tags(img, camera=CAM, tag_size=0.05, z_aligned=True)
    assert det.cMo is not None and al.cMo is not None
    np.testing.assert_allclose(det.cMo[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=0.01)
    np.testing.assert_allclose(al.cMo[:3, :3], np.eye(3), atol=0.01)
    np.testing.assert_allclose(al.cMo[:3, 3], [0.0, 0.0, 0.3], atol=1e-3)
    # corner 0 at (-s/2, -s/2): lower left in the image of a tag facing the camera this way
    assert det.corners[0, 0] < 160.0 and det.corners[0, 1] > 120.0
    # seen from behind, a tag is not drawn
    img_back, _, _ = _shot(make_transform(t=[0.0, 0.0, 0.3]))
    assert detect_tags(img_back) == []


@pytest.mark.parametrize(("family", "tag_id"), [("25h9", 7), ("16h5", 29), ("aruco_4x4_50", 11)])
def test_other_families(family: str, tag_id: int) -> None:
    wMo = make_transform(t=[0.01, 0.0, 0.25], rotvec=FACING + np.array([0.2, -0.1, 0.5]))
    img, truth, _ = _shot(wMo, tag_id=tag_id, family=family)
    dets = detect_tags(img, family)
    assert [d.id for d in dets] == [tag_id]
    assert dets[0].cMo is None and np.isnan(dets[0].reprojection_px)
    assert np.abs(dets[0].corners - truth).max() < 0.2  # no blur: the edges are aliased


def test_distortion_is_used_for_the_pose() -> None:
    wMo = make_transform(t=[0.05, 0.03, 0.25], rotvec=FACING + np.array([0.1, 0.2, 0.0]))
    img, truth, r = _shot(wMo, k1=-0.3)
    (det,) = detect_tags(img, camera=r.optics, tag_size=0.05)
    assert np.abs(det.corners - truth).max() < 0.1
    assert det.cMo is not None and np.linalg.norm(det.cMo[:3, 3] - wMo[:3, 3]) < 1e-3
    (plain,) = detect_tags(img, camera=CAM, tag_size=0.05)  # no distortion: worse
    assert plain.cMo is not None
    assert np.linalg.norm(plain.cMo[:3, 3] - wMo[:3, 3]) > 3e-3
    cam_k = Camera(px=300.0, py=300.0, u0=160.0, v0=120.0, width=320, height=240, k1=-0.3)
    (via_cam,) = detect_tags(img, camera=cam_k, tag_size=0.05)
    assert via_cam.cMo is not None
    np.testing.assert_allclose(via_cam.cMo, det.cMo, atol=1e-9)
    assert isinstance(r.optics, Optics)


def test_bad_input() -> None:
    img = np.zeros((40, 40), np.uint8)
    with pytest.raises(UnknownNameError, match="unknown tag family"):
        detect_tags(img, "37h11")
    with pytest.raises(ShapeError, match="image"):
        detect_tags(img.astype(float))
    with pytest.raises(ConfigurationError, match="needs camera"):
        detect_tags(img, tag_size=0.05)
    with pytest.raises(ConfigurationError, match="tag_size"):
        detect_tags(img, camera=CAM, tag_size=-1.0)
    with pytest.raises(ConfigurationError, match="tag_size"):
        detect_tags(img, camera=CAM, tag_size="5 cm")  # type: ignore[arg-type]
    with pytest.raises(ConfigurationError, match=r"\[0, 29\]"):
        Tag("t", family="16h5", tag_id=30)
    with pytest.raises(GeometryError, match="size"):
        Tag("t", size=0.0)
    assert detect_tags(img) == []


def _run(name: str, *sets: str, start: list[float] | None = None):
    import copy

    from redservo.experiment.build import build
    from redservo.scenario import Scenario, apply_overrides, load_scenario

    sc = load_scenario(name)
    if start is not None:  # a closer start: the tag's translation from the start camera
        data = copy.deepcopy(sc.data)
        data["objects"][0]["pose_in_camera"]["translation"] = start
        sc = Scenario(data, sc.source)
    small = ["camera.px=300", "camera.py=300", "camera.u0=160", "camera.v0=120"]
    small += ["camera.width=320", "camera.height=240"]
    return build(apply_overrides(sc, [*small, *sets])).run()


@pytest.mark.parametrize("name", ["afma6-tag-ibvs", "afma6-tag-pbvs", "afma6-tag-2half-d"])
def test_tag_scenarios_converge_through_images(name: str) -> None:
    """From a closer start, in 320 x 240 images, with λ = 3: converged."""
    res = _run(name, "control.lam=3.0", "simulation.max_iterations=70", start=[0.01, -0.01, 0.33])
    assert res.outcome == "converged", res.outcome
    assert res.summary.success


def test_pbvs_on_detected_poses_matches_the_ideal_sensor() -> None:
    """The first steps of PBVS through images follow those on the exact pose."""
    it = "simulation.max_iterations=5"
    img = _run("afma6-tag-pbvs", it)
    ideal = _run("afma6-tag-pbvs", it, 'sensor.kind="ideal"')
    np.testing.assert_allclose(img.log.e, ideal.log.e, atol=6e-3)  # m and rad


def test_the_image_sensor_refuses_what_it_cannot_measure() -> None:
    from redservo.features import PointFeature, PoseThetaU
    from redservo.scene import PointSet
    from redservo.task import TaskTerm, VisualTask
    from redservo.vision import ImageSensor

    wMo = make_transform(t=[0.0, 0.0, 0.3], rotvec=FACING)
    scene = Scene(
        [Tag("tag", size=0.1, trajectory=Static(wMo)), PointSet("dots", [[0.0, 0.0, 0.3]])]
    )
    cases = [
        (TaskTerm(PoseThetaU("cdRc", wMo), "dots"), "pose feature on a tag only"),
        (TaskTerm(PointFeature([0.0, 0.0, 0.0]), "tag"), "one of its 4 corners"),
    ]
    for term, message in cases:
        task = VisualTask.from_desired_poses([term], {term.target: wMo})
        with pytest.raises(ConfigurationError, match=message):
            ImageSensor(CAM).read(task, scene, np.eye(4), 0.0)
