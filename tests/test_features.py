"""Tests of the visual features (redservo.features).

Every interaction matrix is checked against a central finite difference of the
feature value under a small camera motion ``cMo' = inv(exp_twist(±h e_j)) @ cMo``
at many random valid poses; reference matrices from the papers are written out
independently here.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo.errors import ConfigurationError, GeometryError, ShapeError
from redservo.features.base import Feature
from redservo.features.line import (
    CylinderFeature,
    LineFeature,
    cylinder_lines,
    line_interaction,
    project_line,
)
from redservo.features.point import PointFeature
from redservo.features.sphere import SphereFeature, sphere_ellipse, sphere_moments_from_area
from redservo.spatial import exp_twist, inverse, make_transform

H = 1e-6
TOL = 1e-6


def fd_interaction(feat: Feature, cMo: np.ndarray, h: float = H) -> np.ndarray:
    """Central finite difference of s under camera twists ±h e_j (angle errors wrapped)."""
    L = np.zeros((feat.size, 6))
    for j in range(6):
        e = np.zeros(6)
        e[j] = h
        sp = feat.value(inverse(exp_twist(e)) @ cMo)
        sm = feat.value(inverse(exp_twist(-e)) @ cMo)
        L[:, j] = feat.error(sp, sm) / (2 * h)
    return L


def assert_fd_matches(feat: Feature, cMo: np.ndarray) -> None:
    s, L = feat.value_and_interaction(cMo)
    assert np.all(np.isfinite(s)) and np.all(np.isfinite(L))
    L_fd = fd_interaction(feat, cMo)
    scale = max(1.0, float(np.abs(L).max()))
    np.testing.assert_allclose(L, L_fd, rtol=0, atol=TOL * scale)


def random_poses(
    rng: np.random.Generator, count: int, *, xy: float, z: tuple[float, float], rot: float
) -> list[np.ndarray]:
    return [
        make_transform(
            t=[rng.normal() * xy, rng.normal() * xy, rng.uniform(*z)],
            rotvec=rng.normal(size=3) * rot,
        )
        for _ in range(count)
    ]


def check_fd_on_valid_poses(
    feat: Feature, poses: list[np.ndarray], min_valid: int
) -> list[np.ndarray]:
    """FD-check every pose where the feature is valid; return the valid poses."""
    valid = []
    for cMo in poses:
        try:
            feat.measure(cMo)
            # Stay clear of the validity boundary so that ±h stays valid.
            for j in range(6):
                e = np.zeros(6)
                e[j] = 10 * H
                feat.measure(inverse(exp_twist(e)) @ cMo)
                feat.measure(inverse(exp_twist(-e)) @ cMo)
        except GeometryError:
            continue
        assert_fd_matches(feat, cMo)
        valid.append(cMo)
    assert len(valid) >= min_valid
    return valid


# --------------------------------------------------------------------------- point


def test_point_interaction_equals_cm01_eq26() -> None:
    x, y, Z = 0.3, -0.2, 1.7
    feat = PointFeature([x * Z, y * Z, Z])
    s, L = feat.value_and_interaction(np.eye(4))
    assert np.allclose(s, [x, y])
    # CM01 eq. (26), transposed back to L (X, Y normalized coordinates, z the depth).
    eq26 = np.array(
        [
            [-1 / Z, 0, x / Z, x * y, -(1 + x**2), y],
            [0, -1 / Z, y / Z, 1 + y**2, -x * y, -x],
        ]
    )
    assert np.allclose(L, eq26, atol=1e-15)


@settings(max_examples=60, deadline=None)
@given(
    p=st.tuples(*[st.floats(-0.3, 0.3)] * 3),
    t=st.tuples(st.floats(-0.4, 0.4), st.floats(-0.4, 0.4), st.floats(0.6, 3.0)),
    r=st.tuples(*[st.floats(-0.4, 0.4)] * 3),
)
def test_point_interaction_matches_finite_difference(
    p: tuple[float, float, float], t: tuple[float, float, float], r: tuple[float, float, float]
) -> None:
    assert_fd_matches(PointFeature(p), make_transform(t=t, rotvec=r))


@pytest.mark.parametrize("z", [0.0, -0.5, 1e-9])
def test_point_behind_camera_raises(z: float) -> None:
    with pytest.raises(GeometryError, match="behind the camera"):
        PointFeature([0.1, 0.1, z]).measure(np.eye(4))


def test_point_wrong_shapes_raise() -> None:
    with pytest.raises(ShapeError):
        PointFeature([0.0, 0.0])
    feat = PointFeature()
    with pytest.raises(ShapeError):
        feat.interaction(np.zeros(3), np.ones(1))
    with pytest.raises(ShapeError):
        feat.interaction(np.zeros(2), np.array([np.nan]))
    with pytest.raises(ShapeError):
        feat.measure(np.eye(3))


# --------------------------------------------------------------------------- line


def test_line_interaction_matches_finite_difference() -> None:
    rng = np.random.default_rng(10)
    for _ in range(4):
        feat = LineFeature(rng.normal(size=3) * 0.2, rng.normal(size=3))
        poses = random_poses(rng, 15, xy=0.3, z=(0.5, 2.0), rot=0.6)
        check_fd_on_valid_poses(feat, poses, min_valid=12)


def test_line_parameters_describe_the_image_of_the_3d_line() -> None:
    rng = np.random.default_rng(11)
    for _ in range(20):
        P0 = rng.normal(size=3) + np.array([0.0, 0.0, 3.0])
        u = rng.normal(size=3)
        rho, theta, _ = project_line(P0, u)
        assert -np.pi < theta <= np.pi
        for lam in (-0.5, 0.0, 0.7):
            X = P0 + lam * u
            x, y = X[:2] / X[2]
            assert abs(x * np.cos(theta) + y * np.sin(theta) - rho) < 1e-12


def test_line_interaction_does_not_depend_on_the_plane_of_the_pencil() -> None:
    P0, u = np.array([0.2, -0.1, 1.5]), np.array([1.0, 0.4, 0.3])
    rho, theta, plane = project_line(P0, u)
    # Another plane through the line: normal orthogonal to u, not through the origin.
    n = np.cross(u, [0.3, 1.0, -0.2])
    D = -n @ P0
    assert abs(D) > 1e-3
    L1 = line_interaction(rho, theta, plane)
    L2 = line_interaction(rho, theta, n / D)
    assert np.allclose(L1, L2, atol=1e-12)


def test_line_degenerate_cases_raise() -> None:
    with pytest.raises(GeometryError, match="zero-length axis"):
        LineFeature([0, 0, 1], [0, 0, 0])
    with pytest.raises(GeometryError, match="optical centre"):
        LineFeature([0, 0, 1], [0, 0, 1]).measure(np.eye(4))
    with pytest.raises(GeometryError, match="behind"):
        LineFeature([0, 0, -1], [1, 0, 0]).measure(np.eye(4))
    with pytest.raises(GeometryError, match="Z = 0"):
        LineFeature([0, 1, 0], [1, 0, 0]).measure(np.eye(4))


# --------------------------------------------------------------------------- cylinder


def test_cylinder_both_limbs_match_finite_difference() -> None:
    rng = np.random.default_rng(12)
    for _ in range(4):
        feat = CylinderFeature(
            float(rng.uniform(0.02, 0.15)), rng.normal(size=3), rng.normal(size=3) * 0.1
        )
        poses = random_poses(rng, 15, xy=0.3, z=(0.6, 2.0), rot=0.6)
        check_fd_on_valid_poses(feat, poses, min_valid=10)


def test_cylinder_cm01_desired_values_and_rank() -> None:
    R, Zs = 0.05, 0.6
    feat = CylinderFeature(R, axis=[0, 1, 0])
    cMo = make_transform(t=[0.0, 0.0, Zs])
    s, L = feat.value_and_interaction(cMo)
    rho = -R / np.sqrt(Zs**2 - R**2)
    assert np.allclose(s, [rho, 0.0, rho, np.pi], atol=1e-15)
    assert s[3] == np.pi  # reported in (-π, π]
    assert L.shape == (4, 6)
    assert np.linalg.matrix_rank(L, tol=1e-10) == 4
    # Translation along the axis and rotation about it leave the image unchanged.
    assert np.allclose(L @ [0, 1, 0, 0, 0, 0], 0.0, atol=1e-14)
    X0, a = np.array([0, 0, Zs]), np.array([0, 1, 0])
    assert np.allclose(L @ np.concatenate([np.cross(X0, a), a]), 0.0, atol=1e-14)
    # Flipping the axis swaps the labels.
    s_flip = CylinderFeature(R, axis=[0, -1, 0]).value(cMo)
    assert np.allclose(s_flip, [rho, np.pi, rho, 0.0], atol=1e-15)


def test_cylinder_limbs_are_tangent_planes() -> None:
    rng = np.random.default_rng(13)
    for _ in range(20):
        R = float(rng.uniform(0.05, 0.3))
        a = rng.normal(size=3)
        a /= np.linalg.norm(a)
        X0 = rng.normal(size=3) + np.array([0.0, 0.0, 2.0])
        try:
            s, _ = cylinder_lines(R, a, X0)
        except GeometryError:
            continue
        for rho, theta in (s[:2], s[2:]):
            # Interpretation plane of the image line: n = (cos θ, sin θ, -ρ), through the origin.
            n = np.array([np.cos(theta), np.sin(theta), -rho])
            n /= np.linalg.norm(n)
            assert abs(n @ a) < 1e-12  # contains the axis direction
            assert abs(abs(n @ X0) - R) < 1e-12  # at distance R from the axis


def test_cylinder_theta_error_wraps_across_pi() -> None:
    feat = CylinderFeature(0.05, axis=[0, 1, 0])
    s_star = feat.value(make_transform(t=[0, 0, 0.6]))
    s = feat.value(make_transform(t=[0, 0, 0.6], rotvec=[0, 0, 0.01]))
    assert s[3] < -3.0  # θ2 crossed the branch cut
    e = feat.error(s, s_star)
    assert np.all(np.abs(e) < 0.05)
    assert np.isclose(e[1], e[3], atol=1e-12)


def test_cylinder_invalid_geometry_raises() -> None:
    with pytest.raises(GeometryError, match="zero-length axis"):
        CylinderFeature(0.1, axis=[0, 0, 0])
    with pytest.raises(GeometryError, match="radius"):
        CylinderFeature(-0.1, axis=[0, 1, 0])
    feat = CylinderFeature(0.1, axis=[0, 1, 0])
    for z in (0.05, 0.1, 0.0):  # inside, on the surface, on the axis
        with pytest.raises(GeometryError, match="inside or on the cylinder"):
            feat.measure(make_transform(t=[0, 0, z]))
    with pytest.raises(GeometryError, match="behind"):
        feat.measure(make_transform(t=[0, 0, -1.0]))
    with pytest.raises(ShapeError):
        feat.interaction(np.zeros(3), np.ones(3))


# --------------------------------------------------------------------------- sphere


@pytest.mark.parametrize("variant", ["exact", "moments"])
def test_sphere_interaction_matches_finite_difference(variant: str) -> None:
    rng = np.random.default_rng(14)
    for _ in range(3):
        feat = SphereFeature(
            float(rng.uniform(0.03, 0.2)), rng.normal(size=3) * 0.1, variant=variant
        )
        poses = random_poses(rng, 20, xy=0.4, z=(0.4, 2.0), rot=0.6)
        check_fd_on_valid_poses(feat, poses, min_valid=15)


def test_sphere_exact_matrix_at_on_axis_desired_pose() -> None:
    zd, r = 0.9, 0.1
    feat = SphereFeature(r)
    s, L = feat.value_and_interaction(make_transform(t=[0, 0, zd]))
    R2 = r**2 / (zd**2 - r**2)  # image radius squared
    assert np.allclose(s, [0, 0, np.pi * R2], atol=1e-15)
    k = (1 + R2) / zd
    expected = np.array(
        [
            [-k, 0, 0, 0, -(1 + R2), 0],
            [0, -k, 0, 1 + R2, 0, 0],
            [0, 0, 2 * np.pi * R2 * (1 + R2) / zd, 0, 0, 0],
        ]
    )
    assert np.allclose(L, expected, atol=1e-12)
    assert np.isclose(L[0, 0], -1.125)
    assert np.isclose(L[2, 2], 0.0884, atol=5e-5)


def test_sphere_paper_variant_equals_cm01_eq27_at_desired_pose() -> None:
    zd, r = 0.9, 0.1
    feat = SphereFeature(r, variant="paper")
    _, L = feat.value_and_interaction(make_transform(t=[0, 0, zd]))
    R2 = r**2 / (zd**2 - r**2)
    eq27 = np.array(
        [
            [-1 / zd, 0, 0, 0, -1 - R2, 0],
            [0, -1 / zd, 0, 1 + R2, 0, 0],
            [0, 0, np.pi * R2 / zd, 0, 0, 0],
        ]
    )
    assert np.allclose(L, eq27, atol=1e-12)
    assert np.isclose(L[0, 0], -1.1111, atol=1e-4)
    assert np.isclose(L[2, 2], 0.0436, atol=1e-4)


def test_sphere_ellipse_matches_the_tangent_cone_conic() -> None:
    """Centre, area and moments against the conic of rays tangent to the sphere."""
    rng = np.random.default_rng(15)
    for _ in range(30):
        r = float(rng.uniform(0.05, 0.3))
        X0 = np.array([*rng.normal(size=2) * 0.5, rng.uniform(0.5, 2.0)])
        if X0[2] <= r + 0.01:
            continue
        img = sphere_ellipse(r, X0)
        # Ray p = (x, y, 1) is tangent iff |X0|²|p|² - (X0·p)² = r²|p|²: p^T M p = 0.
        M = (X0 @ X0 - r**2) * np.eye(3) - np.outer(X0, X0)
        M2, m, m0 = -M[:2, :2], -M[:2, 2], -M[2, 2]  # inside the ellipse: p^T(-M)p <= 0
        c = -np.linalg.solve(M2, m)
        kappa = -(m0 - m @ np.linalg.solve(M2, m))  # (x - c)^T M2 (x - c) <= kappa
        S = kappa * np.linalg.inv(M2)  # ellipse shape matrix
        assert np.allclose([img.xc, img.yc], c, atol=1e-12)
        assert np.isclose(img.area, np.pi * np.sqrt(np.linalg.det(S)), rtol=1e-10)
        assert np.allclose([[img.n20, img.n11], [img.n11, img.n02]], S / 4, atol=1e-12)
        # The moments follow from (xc, yc, a) alone.
        assert np.allclose(
            sphere_moments_from_area(img.xc, img.yc, img.area),
            [img.n20, img.n11, img.n02],
            atol=1e-14,
        )
        # Limb plane: 1/Z = A x + B y + C on the contour generator.
        assert np.allclose(img.plane, X0 / (X0 @ X0 - r**2))


def test_sphere_invalid_geometry_raises() -> None:
    feat = SphereFeature(0.1)
    for t in ([0, 0, 0.05], [0, 0, 0.1], [0.0, 0.0, 0.0]):
        with pytest.raises(GeometryError, match="inside or on the sphere"):
            feat.measure(make_transform(t=t))
    for t in ([0.5, 0, 0.05], [0, 0.3, -1.0]):
        with pytest.raises(GeometryError, match="not entirely in front"):
            feat.measure(make_transform(t=t))
    with pytest.raises(GeometryError, match="radius"):
        SphereFeature(0.0)
    with pytest.raises(ConfigurationError, match="exact, paper, moments"):
        SphereFeature(0.1, variant="ellipse")  # type: ignore[arg-type]
    with pytest.raises(ShapeError):
        SphereFeature(0.1, variant="moments").interaction(np.zeros(3), np.ones(3))
