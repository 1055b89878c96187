"""Tests of redservo.spatial against independent references (scipy, matrix exponential, FD)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from redservo.errors import ShapeError
from redservo.spatial import (
    exp_twist,
    inverse,
    log_transform,
    make_transform,
    matrix_to_rotvec,
    rotvec_to_matrix,
    rpy_to_matrix,
    skew,
    transform_point,
    transform_points,
    twist_transform,
)

finite = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)
vec3 = arrays(np.float64, 3, elements=finite)
vec6 = arrays(np.float64, 6, elements=finite)


def twist_matrix(xi: np.ndarray) -> np.ndarray:
    """The 4x4 se(3) matrix [[ [w]x, v ], [0, 0]] written out by hand."""
    v, w = xi[:3], xi[3:]
    X = np.zeros((4, 4))
    X[:3, :3] = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
    X[:3, 3] = v
    return X


def random_transform(rng: np.random.Generator) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.normal(size=3)
    return T


@given(vec3, vec3)
@settings(max_examples=50, deadline=None)
def test_skew_is_cross_product(w: np.ndarray, p: np.ndarray) -> None:
    assert np.allclose(skew(w) @ p, np.cross(w, p), atol=1e-12)
    assert np.allclose(skew(w), -skew(w).T)


@given(vec3)
@settings(max_examples=100, deadline=None)
def test_rotvec_to_matrix_matches_scipy(r: np.ndarray) -> None:
    assert np.allclose(rotvec_to_matrix(r), Rotation.from_rotvec(r).as_matrix(), atol=1e-12)


@pytest.mark.parametrize("scale", [0.0, 1e-12, 1e-9, 1e-7, 1e-3, np.pi - 1e-6, np.pi])
def test_rotvec_to_matrix_small_and_large_angles(scale: float) -> None:
    u = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    R = rotvec_to_matrix(scale * u)
    assert np.allclose(R, Rotation.from_rotvec(scale * u).as_matrix(), atol=1e-14)
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-14)


@given(vec3)
@settings(max_examples=100, deadline=None)
def test_rotvec_round_trip(r: np.ndarray) -> None:
    theta = np.linalg.norm(r)
    if theta > np.pi - 1e-3:  # keep the angle in [0, pi) so the rotation vector is unique
        r = r / theta * (theta % (np.pi - 1e-3))
    assert np.allclose(matrix_to_rotvec(rotvec_to_matrix(r)), r, atol=1e-9)


def test_matrix_to_rotvec_rejects_bad_shape() -> None:
    with pytest.raises(ShapeError):
        matrix_to_rotvec(np.eye(4))
    with pytest.raises(ShapeError):
        matrix_to_rotvec(np.full((3, 3), np.nan))


@given(vec6, st.floats(0.01, 2.0))
@settings(max_examples=100, deadline=None)
def test_exp_twist_matches_matrix_exponential(xi: np.ndarray, dt: float) -> None:
    assert np.allclose(exp_twist(xi, dt), expm(twist_matrix(xi) * dt), atol=1e-9)


@pytest.mark.parametrize("wscale", [0.0, 1e-12, 1e-9, 1e-7, 1e-5])
def test_exp_twist_small_rotation_branch(wscale: float) -> None:
    xi = np.array([0.1, -0.2, 0.3, 0.4 * wscale, -0.7 * wscale, 0.2 * wscale])
    assert np.allclose(exp_twist(xi), expm(twist_matrix(xi)), atol=1e-14)


@given(vec6)
@settings(max_examples=100, deadline=None)
def test_log_exp_round_trip(xi: np.ndarray) -> None:
    theta = np.linalg.norm(xi[3:])
    if theta > np.pi - 1e-3:  # log returns the rotation angle in [0, pi]
        xi = np.concatenate([xi[:3], xi[3:] / theta * (theta % (np.pi - 1e-3))])
    assert np.allclose(log_transform(exp_twist(xi)), xi, atol=1e-8)


def test_exp_log_round_trip_on_random_transforms() -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        T = random_transform(rng)
        assert np.allclose(exp_twist(log_transform(T)), T, atol=1e-9)
    # Tiny rotation (the series branch of log).
    T = make_transform(t=(0.3, 0.1, -0.2), rotvec=(1e-10, -2e-10, 0.0))
    assert np.allclose(exp_twist(log_transform(T)), T, atol=1e-14)


def test_inverse() -> None:
    rng = np.random.default_rng(2)
    for _ in range(20):
        T = random_transform(rng)
        assert np.allclose(inverse(T) @ T, np.eye(4), atol=1e-12)
        assert np.allclose(inverse(T), np.linalg.inv(T), atol=1e-12)


def _inverse_reference(T: np.ndarray) -> np.ndarray:
    """The inverse as first written (block by block): the faster one must match it bitwise."""
    Rt = T[:3, :3].T
    out = np.empty((4, 4))
    out[:3, :3] = Rt
    out[:3, 3] = -(Rt @ T[:3, 3])
    out[3] = (0.0, 0.0, 0.0, 1.0)
    return out


def test_inverse_is_bit_identical_to_the_block_formula() -> None:
    """Every bit, for C- and F-ordered, strided and float32 inputs, a bottom row off by 1e-10
    and zero translations (the sign of a zero included)."""
    rng = np.random.default_rng(3)
    for i in range(400):
        T = random_transform(rng)
        T[:3, 3] *= (0.0, 1e-3, 1.0, 100.0)[i % 4]
        if i % 5 == 0:
            T[3] = (1e-10, -1e-10, 0.0, 1.0 + 1e-10)
        if i % 3 == 0:
            T = np.asfortranarray(T)
        if i % 7 == 0:
            big = np.zeros((8, 8))
            big[::2, ::2] = T
            T = big[::2, ::2]
        if i % 11 == 0:
            T = T.astype(np.float32)
        got, want = inverse(T), _inverse_reference(T)
        assert got.dtype == want.dtype == np.float64 and got.flags.c_contiguous
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64))


def test_twist_transform_matches_finite_differences_of_a_moving_frame() -> None:
    """Frames a and b are rigidly attached; the body moves with twist v_b (in b).

    The pose of a is ``wMa(t) = wMb(t) · bMa`` and its body twist is
    ``log(wMa(0)^-1 wMa(h)) / h``; twist_transform(aMb) must map v_b to it.
    """
    rng = np.random.default_rng(3)
    for _ in range(10):
        wMb0 = random_transform(rng)
        aMb = random_transform(rng)
        bMa = inverse(aMb)
        v_b = rng.normal(size=6)
        h = 1e-6

        def wMa(
            t: float, wMb0: np.ndarray = wMb0, v_b: np.ndarray = v_b, bMa: np.ndarray = bMa
        ) -> np.ndarray:
            return wMb0 @ exp_twist(v_b, t) @ bMa

        T0 = wMa(0.0)
        v_a_fd = (log_transform(inverse(T0) @ wMa(h)) - log_transform(inverse(T0) @ wMa(-h))) / (
            2 * h
        )
        assert np.allclose(twist_transform(aMb) @ v_b, v_a_fd, atol=1e-7)


def test_twist_transform_group_properties() -> None:
    rng = np.random.default_rng(4)
    A, B = random_transform(rng), random_transform(rng)
    assert np.allclose(twist_transform(A @ B), twist_transform(A) @ twist_transform(B))
    assert np.allclose(twist_transform(inverse(A)), np.linalg.inv(twist_transform(A)))
    # A point fixed in the moving frame b at its origin: v_a = R v_b + t x (R w_b).
    R, t = A[:3, :3], A[:3, 3]
    v_b = rng.normal(size=6)
    V = twist_transform(A) @ v_b
    assert np.allclose(V[:3], R @ v_b[:3] + np.cross(t, R @ v_b[3:]))
    assert np.allclose(V[3:], R @ v_b[3:])


def test_make_transform_and_points() -> None:
    T = make_transform(t=(1.0, 2.0, 3.0), rotvec=(0.0, 0.0, np.pi / 2))
    assert np.allclose(transform_point(T, [1.0, 0.0, 0.0]), [1.0, 3.0, 3.0])
    P = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    assert np.allclose(transform_points(T, P), [[1.0, 3.0, 3.0], [0.0, 2.0, 3.0]])
    R = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix()
    assert np.allclose(make_transform(R=R)[:3, :3], R)
    with pytest.raises(ShapeError):
        make_transform(t=(1.0, 2.0))


def test_rpy_to_matrix_is_z_y_x_product() -> None:
    r, p, y = 0.3, -0.4, 1.1
    Rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    Ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    Rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    assert np.allclose(rpy_to_matrix((r, p, y)), Rz @ Ry @ Rx)
    assert np.allclose(rpy_to_matrix(np.degrees((r, p, y)), degrees=True), Rz @ Ry @ Rx)
