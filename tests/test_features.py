"""Tests of the visual features (redservo.features).

Every interaction matrix is checked against a central finite difference of the
feature value under a small camera motion ``cMo' = inv(exp_twist(±h e_j)) @ cMo``
at many random valid poses; reference matrices from the papers are written out
independently here.
"""

from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from redservo.errors import ConfigurationError, GeometryError, ShapeError, UnknownNameError
from redservo.features import (
    FEATURES,
    CylinderFeature,
    Feature,
    LineFeature,
    LogDepth,
    MomentFeatures,
    PointFeature,
    PoseThetaU,
    PoseTranslation,
    SphereFeature,
    centred_moment_interaction,
    cylinder_lines,
    image_moments,
    line_interaction,
    make_feature,
    moment_features,
    object_plane,
    project_line,
    rotation_invariants,
    sphere_ellipse,
    sphere_moments_from_area,
)
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


# --------------------------------------------------------------------------- moments

# A non-symmetric planar target (4 dots, as in MC05, plus one) in the plane z = 0.
DOTS = np.array(
    [[-0.08, -0.05, 0.0], [0.10, -0.04, 0.0], [0.05, 0.07, 0.0], [-0.06, 0.09, 0.0], [0.0, 0.02, 0]]
)
KINDS = ["c4c6", "pxpy", "sxsy"]


def test_centred_moment_interaction_matches_finite_difference_on_tilted_planes() -> None:
    rng = np.random.default_rng(16)
    n_tilted = 0
    for cMo in random_poses(rng, 15, xy=0.1, z=(0.4, 1.0), rot=0.6):
        P = DOTS @ cMo[:3, :3].T + cMo[:3, 3]
        plane = object_plane(P)
        n_tilted += bool(np.hypot(plane[0], plane[1]) > 0.3)
        mom = image_moments(P[:, :2] / P[:, 2:])
        for i, j in [(i, j) for i in range(4) for j in range(4) if 1 < i + j <= 3]:
            L = centred_moment_interaction(i, j, mom, plane)
            fd = np.zeros(6)
            for k in range(6):
                e = np.zeros(6)
                e[k] = H
                vals = []
                for sign in (1, -1):
                    T = inverse(exp_twist(sign * e)) @ cMo
                    Q = DOTS @ T[:3, :3].T + T[:3, 3]
                    vals.append(image_moments(Q[:, :2] / Q[:, 2:]).mu[i, j])
                fd[k] = (vals[0] - vals[1]) / (2 * H)
            np.testing.assert_allclose(L, fd, atol=1e-8)
    assert n_tilted >= 5


@pytest.mark.parametrize("kind", KINDS)
def test_moment_features_match_finite_difference_on_tilted_planes(kind: str) -> None:
    rng = np.random.default_rng(17)
    feat = MomentFeatures.at_desired_pose(
        DOTS, make_transform(t=[0, 0, 0.5]), rotation_features=kind
    )
    poses = random_poses(rng, 40, xy=0.1, z=(0.3, 1.0), rot=0.5)
    valid = check_fd_on_valid_poses(feat, poses, min_valid=35)
    tilts = [np.hypot(*feat.measure(T).inv_depth[:2]) for T in valid]
    assert sum(t > 0.3 for t in tilts) >= 10  # general planes, A and B non-zero


@pytest.mark.parametrize("kind", ["c4c6", "pxpy"])
def test_moment_features_at_a_parallel_pose(kind: str) -> None:
    Zs = 0.5
    feat = MomentFeatures.at_desired_pose(
        DOTS, make_transform(t=[0, 0, Zs]), rotation_features=kind
    )
    # A different parallel pose: shifted, closer, rotated about the optical axis.
    cMo = make_transform(t=[0.03, -0.02, 0.4], rotvec=[0, 0, 0.3])
    m = feat.measure(cMo)
    L = feat.interaction(m.s, m.inv_depth)
    assert np.allclose(m.inv_depth, [0, 0, 1 / 0.4])
    assert np.isclose(m.s[2], 0.4)  # an = Z at a parallel pose
    assert np.allclose(L[:3, :3], -np.eye(3), atol=1e-12)
    # α: no v columns, ω_z column -1; r1, r2: only ω_x and ω_y.
    assert np.allclose(L[3, :3], 0.0, atol=1e-12) and np.isclose(L[3, 5], -1.0)
    assert np.allclose(L[4:, :3], 0.0, atol=1e-10)
    assert np.allclose(L[4:, 5], 0.0, atol=1e-10)
    assert np.linalg.matrix_rank(L) == 6


def test_moment_rotational_columns_at_parallel_pose_match_the_published_form() -> None:
    """docs/formulas.md §3.4: closed-form ω columns of xn, yn, an, α at a parallel pose."""
    feat = MomentFeatures.at_desired_pose(DOTS, make_transform(t=[0, 0, 0.5]))
    cMo = make_transform(t=[0.05, 0.04, 0.7], rotvec=[0, 0, -0.4])
    m = feat.measure(cMo)
    L = feat.interaction(m.s, m.inv_depth)
    P = DOTS @ cMo[:3, :3].T + cMo[:3, 3]
    xy = P[:, :2] / P[:, 2:]
    N = len(xy)
    xg, yg = xy.mean(axis=0)
    d = xy - [xg, yg]

    def mu(i: int, j: int) -> float:
        return float(np.sum(d[:, 0] ** i * d[:, 1] ** j))

    def n(i: int, j: int) -> float:
        return mu(i, j) / N

    an = m.s[2]
    xn, yn = an * xg, an * yg
    den = n(2, 0) + n(0, 2)
    tx = (n(3, 0) + n(1, 2) + xg * n(2, 0) + yg * n(1, 1)) / den
    ty = (n(2, 1) + n(0, 3) + xg * n(1, 1) + yg * n(0, 2)) / den
    D = (mu(2, 0) - mu(0, 2)) ** 2 + 4 * mu(1, 1) ** 2
    beta, gamma = 2, 1
    awx = (
        beta * (mu(1, 2) * (mu(2, 0) - mu(0, 2)) + mu(1, 1) * (mu(0, 3) - mu(2, 1)))
        + gamma * xg * (mu(0, 2) * (mu(2, 0) - mu(0, 2)) - 2 * mu(1, 1) ** 2)
        + gamma * yg * mu(1, 1) * (mu(2, 0) + mu(0, 2))
    ) / D
    awy = (
        beta * (mu(2, 1) * (mu(0, 2) - mu(2, 0)) + mu(1, 1) * (mu(3, 0) - mu(1, 2)))
        + gamma * xg * mu(1, 1) * (mu(2, 0) + mu(0, 2))
        + gamma * yg * (mu(2, 0) * (mu(0, 2) - mu(2, 0)) - 2 * mu(1, 1) ** 2)
    ) / D
    expected = np.array(
        [
            [an * (n(1, 1) - xg * ty), -an * (1 + n(2, 0) - xg * tx), yn],
            [an * (1 + n(0, 2) - yg * ty), -an * (n(1, 1) - yg * tx), -xn],
            [-an * (yg + ty), an * (xg + tx), 0.0],
            [awx, awy, -1.0],
        ]
    )
    assert np.allclose(L[:4, 3:], expected, atol=1e-12)


@pytest.mark.parametrize("kind", ["c4c6", "pxpy"])
def test_rotation_features_are_similarity_invariant(kind: str) -> None:
    rng = np.random.default_rng(18)
    for _ in range(20):
        xy = rng.normal(size=(int(rng.integers(4, 8)), 2))
        th, sc = rng.uniform(-np.pi, np.pi), rng.uniform(0.3, 3.0)
        R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
        xy2 = sc * xy @ R.T + rng.normal(size=2)
        keys = ((2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3))
        r1 = rotation_invariants([image_moments(xy).mu[k] for k in keys], kind)  # type: ignore[arg-type]
        r2 = rotation_invariants([image_moments(xy2).mu[k] for k in keys], kind)  # type: ignore[arg-type]
        assert np.allclose(r1, r2, rtol=1e-7, atol=1e-12)


def test_sxsy_rotate_with_the_image_and_scale_for_points() -> None:
    xy = np.random.default_rng(19).normal(size=(5, 2))
    keys = ((2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3))

    def sxsy(p: np.ndarray) -> np.ndarray:
        return rotation_invariants([image_moments(p).mu[k] for k in keys], "sxsy")

    assert np.allclose(sxsy(2.0 * xy), 2.0 * sxsy(xy))  # scales as s^1 for points
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    assert not np.allclose(sxsy(xy @ R.T), sxsy(xy), atol=1e-3)
    assert np.isclose(np.linalg.norm(sxsy(xy @ R.T)), np.linalg.norm(sxsy(xy)))


def test_desired_from_gives_area_and_depth() -> None:
    cMo = make_transform(t=[0.0, 0.0, 0.5])
    P = DOTS @ cMo[:3, :3].T + cMo[:3, 3]
    target = MomentFeatures.desired_from(P)
    xy = P[:, :2] / 0.5
    d = xy - xy.mean(axis=0)
    assert np.isclose(target.area, np.sum(d**2))
    assert np.isclose(target.depth, 0.5)
    feat = MomentFeatures(DOTS, desired_area=target.area, desired_depth=target.depth)
    s = feat.value(cMo)
    assert np.isclose(s[2], 0.5)
    # Tilted desired pose: Z* is the plane depth along the centroid ray.
    cMo = make_transform(t=[0.02, 0.0, 0.6], rotvec=[0.4, 0.2, 0.0])
    P = DOTS @ cMo[:3, :3].T + cMo[:3, 3]
    A, B, C = object_plane(P)
    xg, yg = (P[:, :2] / P[:, 2:]).mean(axis=0)
    assert np.isclose(MomentFeatures.desired_from(P).depth, 1 / (A * xg + B * yg + C))


def test_object_plane_from_camera_points() -> None:
    rng = np.random.default_rng(20)
    for _ in range(10):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        d = float(rng.uniform(0.5, 2.0))
        # Points on n·X = d, then 1/Z = (n/d)·(x, y, 1).
        basis = np.linalg.svd(n[None, :])[2][1:]
        P = d * n + rng.normal(size=(6, 2)) @ basis
        assert np.allclose(object_plane(P), n / d)
        for X in P:
            assert np.isclose(1 / X[2], object_plane(P) @ (X / X[2]))


def test_alpha_error_wraps_with_period_pi() -> None:
    feat = MomentFeatures.at_desired_pose(DOTS, make_transform(t=[0, 0, 0.5]))
    s_star = np.array([0, 0, 0.5, 1.5, 0, 0])
    s = np.array([0, 0, 0.5, -1.5, 0, 0])
    assert np.isclose(feat.error(s, s_star)[3], np.pi - 3.0)
    assert feat.angular == (False, False, False, True, False, False)


def test_interaction_uses_the_measured_moments_nearest_to_s() -> None:
    feat = MomentFeatures.at_desired_pose(DOTS, make_transform(t=[0, 0, 0.5]))
    cMo = make_transform(t=[0.02, 0.01, 0.6], rotvec=[0.2, -0.1, 0.3])
    m = feat.measure(cMo)
    L = feat.interaction(m.s, m.inv_depth)
    noisy = m.s + 1e-3
    assert np.allclose(feat.interaction(noisy, m.inv_depth), L)
    fresh = MomentFeatures(DOTS, desired_area=0.04, desired_depth=0.5)
    with pytest.raises(ConfigurationError, match="call measure"):
        fresh.interaction(m.s, m.inv_depth)


def square(side: float = 0.1) -> np.ndarray:
    h = side / 2
    return np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]])


@pytest.mark.parametrize("kind", ["c4c6", "pxpy"])
def test_centrally_symmetric_set_raises(kind: str) -> None:
    rect = np.array([[-0.1, -0.05, 0], [0.1, -0.05, 0], [0.1, 0.05, 0], [-0.1, 0.05, 0]])
    for pts in (square(), rect):
        with pytest.raises(GeometryError):
            MomentFeatures.at_desired_pose(
                pts, make_transform(t=[0, 0, 0.5]), rotation_features=kind
            )  # type: ignore[arg-type]
    with pytest.raises(GeometryError, match="centrally symmetric"):
        MomentFeatures.at_desired_pose(rect, make_transform(t=[0, 0, 0.5]), rotation_features=kind)  # type: ignore[arg-type]


def test_isotropic_set_raises() -> None:
    tri = np.array([[np.cos(a), np.sin(a), 0.0] for a in (0, 2 * np.pi / 3, 4 * np.pi / 3)])
    with pytest.raises(GeometryError, match="isotropic"):
        MomentFeatures.at_desired_pose(0.1 * tri, make_transform(t=[0, 0, 0.5]))


def test_collinear_image_raises() -> None:
    # Viewed edge-on, the object plane contains the optical centre: the image is a segment.
    feat = MomentFeatures(DOTS, desired_area=0.04, desired_depth=0.5)
    with pytest.raises(GeometryError, match="optical centre"):
        feat.measure(make_transform(t=[0, 0.0, 0.5], rotvec=[np.pi / 2, 0, 0]))
    # On collinear image points I6 = 0, so C4 and C6 are 0/0.
    mom = image_moments([[0.0, 0.0], [0.1, 0.05], [0.3, 0.15], [0.35, 0.175]])
    with pytest.raises(GeometryError, match="I6 vanishes"):
        moment_features(mom, area_star=0.04, depth_star=0.5, rotation_features="c4c6")
    s = moment_features(mom, area_star=0.04, depth_star=0.5, rotation_features="pxpy")
    assert np.all(np.isfinite(s))


def test_invalid_point_sets_raise() -> None:
    kw = {"desired_area": 0.04, "desired_depth": 0.5}
    with pytest.raises(GeometryError, match="at least 3"):
        MomentFeatures(DOTS[:2], **kw)
    with pytest.raises(GeometryError, match="collinear"):
        MomentFeatures([[0, 0, 0], [1, 0, 0], [2, 0, 0]], **kw)
    with pytest.raises(GeometryError, match="not coplanar"):
        MomentFeatures(np.vstack([DOTS, [0, 0, 0.05]]), **kw)
    with pytest.raises(ShapeError):
        MomentFeatures(DOTS[:, :2], **kw)
    with pytest.raises(ConfigurationError):
        MomentFeatures(DOTS, desired_area=-1.0, desired_depth=0.5)
    with pytest.raises(ConfigurationError, match="c4c6, pxpy, sxsy"):
        MomentFeatures(DOTS, rotation_features="hu", **kw)  # type: ignore[arg-type]
    feat = MomentFeatures(DOTS, **kw)
    with pytest.raises(GeometryError, match="behind the camera"):
        feat.measure(make_transform(t=[0, 0, 0.05], rotvec=[0.0, 1.2, 0.0]))
    with pytest.raises(ShapeError):
        feat.interaction(np.zeros(5), np.ones(3))


# --------------------------------------------------------------------------- registry


def test_make_feature_builds_every_kind() -> None:
    options: dict[str, dict[str, object]] = {
        "point": {"point_o": [0, 0, 0]},
        "line": {"point": [0, 0, 0], "direction": [1, 0, 0]},
        "cylinder": {"radius": 0.05, "axis": [0, 1, 0]},
        "sphere": {"radius": 0.1, "variant": "paper"},
        "moments": {"points_o": DOTS, "desired_area": 0.04, "desired_depth": 0.5},
        "pose_translation": {"variant": "cMo"},
        "pose_thetau": {"variant": "cdRc", "desired": np.eye(4)},
        "log_depth": {"point_o": [0.01, 0.0, 0.0]},
    }
    assert set(options) == set(FEATURES)
    expected: dict[str, Callable[..., Feature]] = {
        "point": PointFeature,
        "line": LineFeature,
        "cylinder": CylinderFeature,
        "sphere": SphereFeature,
        "moments": MomentFeatures,
        "pose_translation": PoseTranslation,
        "pose_thetau": PoseThetaU,
        "log_depth": LogDepth,
    }
    for kind in FEATURES:
        feat = make_feature(kind, **options[kind])
        assert isinstance(feat, expected[kind])  # type: ignore[arg-type]
        assert len(feat.names) == len(feat.angular) == feat.size
        feat.value(make_transform(t=[0.01, 0.02, 0.7], rotvec=[0.1, 0.0, 0.0]))


def test_make_feature_errors() -> None:
    with pytest.raises(UnknownNameError, match="point, line, cylinder, sphere, moments"):
        make_feature("ellipse")
    with pytest.raises(ConfigurationError, match="sphere"):
        make_feature("sphere", radius=0.1, colour="red")


def test_features_either_raise_geometry_error_or_return_finite_values() -> None:
    """Over wild poses (behind, inside, edge-on, grazing) nothing returns NaN or inf."""
    rng = np.random.default_rng(21)
    features: list[Feature] = [
        PointFeature([0.05, 0.0, 0.0]),
        LineFeature([0, 0, 0], [1, 0.2, 0]),
        CylinderFeature(0.1, axis=[0, 1, 0]),
        SphereFeature(0.1),
        SphereFeature(0.1, variant="moments"),
        SphereFeature(0.1, variant="paper"),
        MomentFeatures(DOTS, desired_area=0.04, desired_depth=0.5),
        MomentFeatures(DOTS, desired_area=0.04, desired_depth=0.5, rotation_features="sxsy"),
    ]
    for feat in features:
        raised = ok = 0
        for cMo in random_poses(rng, 60, xy=0.3, z=(-0.5, 1.0), rot=2.0):
            try:
                m = feat.measure(cMo)
            except GeometryError:
                raised += 1
                continue
            ok += 1
            L = feat.interaction(m.s, m.inv_depth)
            assert np.all(np.isfinite(m.s)) and np.all(np.isfinite(m.inv_depth))
            assert np.all(np.isfinite(L))
        assert ok > 0, feat
        # A line is valid almost everywhere; every other object gets hidden or entered.
        assert raised > 0 or isinstance(feat, LineFeature), feat
