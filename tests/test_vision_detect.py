"""Detectors: dots and their tracking, ellipses, lines, moments, depth from apparent size."""

from __future__ import annotations

import numpy as np
import pytest

from redservo.camera import Camera
from redservo.errors import ConfigurationError, GeometryError
from redservo.features import (
    LineFeature,
    MomentFeatures,
    cylinder_lines,
    image_moments,
    sphere_ellipse,
)
from redservo.scene import Cylinder, PointSet, Scene, Sphere, Static
from redservo.spatial import make_transform, rotvec_to_matrix

cv2 = pytest.importorskip(
    "cv2", reason="the image pipeline needs OpenCV: pip install 'redservo[vision]'"
)

from redservo.vision.depth import (  # noqa: E402
    cylinder_plane,
    estimate_inv_depth,
    point_set_depth,
    sphere_plane,
)
from redservo.vision.dots import DotTracker, detect_dots  # noqa: E402
from redservo.vision.ellipse import detect_ellipse  # noqa: E402
from redservo.vision.lines import find_lines, orient_like, refine_line  # noqa: E402
from redservo.vision.moments import dot_moment_features, region_moments  # noqa: E402
from redservo.vision.render import Renderer, RenderOptions  # noqa: E402

PX = 600.0
DOTS = np.array(
    [[0.01, -0.104, 0.0], [0.107, -0.021, 0.0], [-0.036, 0.09, 0.0], [0.053, -0.054, 0.0]]
)


def _dot_truth(r: Renderer, T: np.ndarray, pts: np.ndarray = DOTS) -> np.ndarray:
    P = pts @ T[:3, :3].T + T[:3, 3]
    return r.optics.to_pixel(P[:, :2] / P[:, 2:])


def _nearest_errors(found: np.ndarray, truth: np.ndarray) -> np.ndarray:
    return np.linalg.norm(truth[:, None, :] - found[None, :, :], axis=2).min(axis=1)


@pytest.mark.parametrize(("noise", "limit"), [(0.0, 0.05), (0.5, 0.1), (1.0, 0.1)])
def test_dot_centroids_are_sub_pixel(noise: float, limit: float) -> None:
    rng = np.random.default_rng(0)
    r = Renderer(options=RenderOptions(noise_px=noise, blur_px=0.5, seed=1))
    errs = []
    for _ in range(15):
        T = make_transform(
            rotvec_to_matrix(rng.normal(0, 0.2, 3)), [*rng.uniform(-0.1, 0.1, 2), 0.8]
        )
        img = r.render(Scene([PointSet("t", DOTS, trajectory=Static(T))]), np.eye(4))
        det = detect_dots(img, threshold=200.0)
        assert det.uv.shape == (4, 2)
        errs.append(_nearest_errors(det.uv, _dot_truth(r, T)))
    assert np.sqrt(np.mean(np.concatenate(errs) ** 2)) <= limit


def test_dots_cut_by_the_border_are_refused() -> None:
    cam = Camera()
    x_edge = (2.0 - cam.u0) / cam.px  # 2 px from the left border
    pts = np.array([[x_edge, 0.0, 1.0], [0.0, 0.0, 1.0]])
    img = Renderer().render(Scene([PointSet("p", pts)]), np.eye(4))
    det = detect_dots(img, threshold=200.0)
    assert det.uv.shape == (1, 2) and det.n_border == 1


def test_tracker_never_swaps_under_fast_motion() -> None:
    # Four dots spinning fast about the optical axis while translating: each frame
    # they move up to about 15 px, more than half the distance between some dots.
    r = Renderer()
    tracker = DotTracker(4, max_jump_px=25.0)
    for k in range(40):
        T = make_transform(rotvec_to_matrix([0.0, 0.0, 0.12 * k]), [0.002 * k, -0.001 * k, 0.8])
        truth = _dot_truth(r, T)
        img = r.render(Scene([PointSet("t", DOTS, trajectory=Static(T))]), np.eye(4))
        if k == 0:
            tracker.start(truth)
        det = detect_dots(img, threshold=200.0)
        rng = np.random.default_rng(k)
        track = tracker.update(det.uv[rng.permutation(len(det.uv))])  # blob order is arbitrary
        assert track.detected.all()
        assert np.abs(track.uv - truth).max() < 0.1, f"frame {k}: dots swapped or lost"


def test_tracker_reports_a_lost_dot_then_gone() -> None:
    tracker = DotTracker(3, max_jump_px=10.0, max_lost_frames=2)
    start = np.array([[100.0, 100.0], [200.0, 100.0], [150.0, 200.0]])
    tracker.start(start)
    tracker.update(start + 1.0)
    for frame in range(4):
        track = tracker.update(start[:2] + 2.0 + frame)  # dot 2 disappeared
        assert list(track.detected) == [True, True, False]
        assert track.n_blobs == 2
        assert track.lost_frames[2] == frame + 1
        assert track.gone == ((2,) if frame + 1 > 2 else ())
    # The lost dot coasts on its last velocity (1 px/frame in u and v).
    assert track.uv[2] == pytest.approx(start[2] + 1.0 + 4.0)
    track = tracker.update(np.vstack([start[:2] + 6.0, track.uv[2]]))
    assert track.detected.all() and track.gone == ()


def test_tracker_refuses_far_blobs_and_needs_start() -> None:
    tracker = DotTracker(1, max_jump_px=5.0)
    with pytest.raises(ConfigurationError, match="start"):
        tracker.update(np.zeros((1, 2)))
    tracker.start([[10.0, 10.0]])
    track = tracker.update([[30.0, 10.0]])
    assert not track.detected[0]


@pytest.mark.parametrize("k1", [0.0, -0.2])
@pytest.mark.parametrize(
    ("method", "centre_px", "rel"), [("moments", 0.02, 0.005), ("contour", 0.1, 0.03)]
)
def test_ellipse_matches_the_sphere_image(
    k1: float, method: str, centre_px: float, rel: float
) -> None:
    r = Renderer(options=RenderOptions(k1=k1, blur_px=0.7))
    for X0, rad in (([0.1, -0.05, 0.8], 0.06), ([-0.25, 0.15, 1.1], 0.08)):
        img = r.render(
            Scene([Sphere("s", rad, trajectory=Static(make_transform(t=X0)))]), np.eye(4)
        )
        meas, why = detect_ellipse(
            img,
            r.optics,
            threshold=100.0,
            method=method,
            pad_px=5.0,
            blur_px=0.7,  # type: ignore[arg-type]
        )
        assert meas is not None, why
        tr = sphere_ellipse(rad, X0)
        assert np.hypot(meas.xc - tr.xc, meas.yc - tr.yc) * PX <= centre_px
        assert meas.area == pytest.approx(tr.area, rel=rel)
        n_true = np.array([tr.n20, tr.n11, tr.n02])
        n_meas = np.array([meas.n20, meas.n11, meas.n02])
        assert np.abs(n_meas - n_true).max() <= rel * max(tr.n20, tr.n02)


def test_ellipse_on_the_border_or_missing_is_reported() -> None:
    r = Renderer()
    img = r.render(
        Scene([Sphere("s", 0.1, trajectory=Static(make_transform(t=[0.55, 0, 1])))]), np.eye(4)
    )
    meas, why = detect_ellipse(img, r.optics, threshold=100.0)
    assert meas is None and "border" in why
    meas, why = detect_ellipse(r.render(Scene([]), np.eye(4)), r.optics, threshold=100.0)
    assert meas is None and "no blob" in why
    with pytest.raises(ConfigurationError, match="method"):
        detect_ellipse(img, r.optics, method="hough")  # type: ignore[arg-type]


@pytest.mark.parametrize("k1", [0.0, -0.2])
def test_cylinder_limbs_match_the_ideal_lines(k1: float) -> None:
    r = Renderer(options=RenderOptions(k1=k1, blur_px=0.5))
    R = rotvec_to_matrix([0.2, -0.1, 0.35])
    X0 = np.array([0.05, 0.0, 0.8])
    img = r.render(
        Scene([Cylinder("c", 0.05, (0, 1, 0), trajectory=Static(make_transform(R, X0)))]), np.eye(4)
    )
    s = cylinder_lines(0.05, R @ [0.0, 1.0, 0.0], X0).s
    for k in range(2):
        rho, theta = s[2 * k], s[2 * k + 1]
        meas, why = refine_line(img, r.optics, rho + 0.004, theta - 0.01, blur_px=0.5)
        assert meas is not None, why
        assert abs(meas.rho - rho) * PX <= 0.05
        assert abs(meas.theta - theta) <= 1e-3
    # A prediction given the other way round, (-ρ, θ + π), keeps that orientation.
    meas, _ = refine_line(img, r.optics, -s[0], s[1] + np.pi - 2 * np.pi, blur_px=0.5)
    assert meas is not None and meas.rho == pytest.approx(-s[0], abs=1e-4)


def test_orient_like_and_find_lines() -> None:
    assert orient_like(0.2, 0.1, -0.2, 0.1 + np.pi) == pytest.approx((-0.2, 0.1 - np.pi))
    assert orient_like(0.2, 0.1, 0.19, 0.12) == pytest.approx((0.2, 0.1))
    r = Renderer()
    img = r.render(
        Scene([Cylinder("c", 0.05, (0, 1, 0), trajectory=Static(make_transform(t=[0, 0, 1])))]),
        np.eye(4),
    )
    s = cylinder_lines(0.05, [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]).s
    found = find_lines(img, r.optics, 2)
    assert len(found) == 2
    for rho, theta in found:
        best = min(
            abs(orient_like(rho, theta, s[2 * k], s[2 * k + 1])[0] - s[2 * k]) for k in range(2)
        )
        assert best * PX < 2.0


def test_moments_from_dots_and_from_a_region() -> None:
    T = make_transform(rotvec_to_matrix([0.1, -0.1, 0.3]), [0.02, -0.03, 0.7])
    feat = MomentFeatures.at_desired_pose(DOTS, make_transform(t=[0, 0, 0.6]))
    P = DOTS @ T[:3, :3].T + T[:3, 3]
    s = dot_moment_features(P[:, :2] / P[:, 2:], feat)
    assert s == pytest.approx(feat.measure(T).s, abs=1e-12)
    # The feature's interaction matrix is evaluated at the given moments.
    assert np.all(np.isfinite(feat.interaction(s, [0.0, 0.0, 1.0 / 0.7])))
    with pytest.raises(GeometryError, match="3 dots"):
        dot_moment_features(P[:2, :2] / P[:2, 2:], feat)
    # Region moments of a rendered sphere: the ellipse's.
    r = Renderer()
    X0, rad = np.array([0.05, 0.02, 0.9]), 0.07
    img = r.render(Scene([Sphere("s", rad, trajectory=Static(make_transform(t=X0)))]), np.eye(4))
    w = np.clip((img.astype(float) - 40.0) / 120.0, 0.0, 1.0)
    mom = region_moments(w, r.optics)
    tr = sphere_ellipse(rad, X0)
    area = mom.mu[0, 0]
    assert area == pytest.approx(tr.area, rel=2e-3)
    assert (mom.xg, mom.yg) == pytest.approx((tr.xc, tr.yc), abs=0.02 / PX)
    assert mom.mu[2, 0] / area == pytest.approx(tr.n20, rel=5e-3)
    with pytest.raises(GeometryError, match="empty"):
        region_moments(np.zeros((4, 4)), r.optics)
    assert image_moments(P[:, :2] / P[:, 2:]).n == 4


def test_depth_from_apparent_size() -> None:
    X0, rad = np.array([0.1, -0.2, 0.9]), 0.07
    e = sphere_ellipse(rad, X0)
    assert sphere_plane([e.xc, e.yc, e.n20, e.n11, e.n02], rad) == pytest.approx(e.plane, rel=1e-9)
    c = cylinder_lines(0.05, [0.2, 1.0, 0.3], [0.1, 0.05, 0.8])
    assert cylinder_plane(c.s, 0.05) == pytest.approx(c.plane, rel=1e-9)
    # A point set parallel to the image plane at 0.75 m.
    P = DOTS + np.array([0.02, 0.01, 0.75])
    assert point_set_depth(DOTS, P[:, :2] / P[:, 2:]) == pytest.approx(0.75, rel=1e-12)
    with pytest.raises(GeometryError, match="two"):
        point_set_depth(DOTS, np.full((4, 2), np.nan))
    with pytest.raises(ConfigurationError, match="no known size"):
        estimate_inv_depth(LineFeature([0, 0, 1], [1, 0, 0]), np.zeros(2))
