"""Small input-validation helpers shared by the package (internal)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo.errors import ShapeError

FloatArray = NDArray[np.float64]


def _to_float(value: ArrayLike, name: str) -> FloatArray:
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ShapeError(
            f"{name} must be numeric and rectangular (a list or array of numbers), got {value!r}"
        ) from None


def as_vector(value: ArrayLike, name: str, size: int | None = None) -> FloatArray:
    """Return ``value`` as a finite 1-D float array, raising :class:`ShapeError` otherwise.

    Args:
        value: Anything numpy can turn into an array.
        name: The argument name, used in the error message.
        size: The required length, or ``None`` for any length.
    """
    arr = _to_float(value, name)
    if arr.ndim != 1 or (size is not None and arr.shape[0] != size):
        want = f"({size},)" if size is not None else "a 1-D array"
        raise ShapeError(f"{name} must have shape {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ShapeError(f"{name} must be finite, got {arr}")
    return arr


def as_matrix(
    value: ArrayLike, name: str, rows: int | None = None, cols: int | None = None
) -> FloatArray:
    """Return ``value`` as a finite 2-D float array, raising :class:`ShapeError` otherwise."""
    arr = _to_float(value, name)
    if (
        arr.ndim != 2
        or (rows is not None and arr.shape[0] != rows)
        or (cols is not None and arr.shape[1] != cols)
    ):
        r = "m" if rows is None else str(rows)
        c = "n" if cols is None else str(cols)
        raise ShapeError(f"{name} must have shape ({r}, {c}), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ShapeError(f"{name} must be finite (no NaN or inf)")
    return arr


def as_transform(value: ArrayLike, name: str) -> FloatArray:
    """Return ``value`` as a 4x4 homogeneous transform with a proper rotation block."""
    T = as_matrix(value, name, 4, 4)
    R = T[:3, :3]
    if (
        not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9)
        or not np.allclose(R @ R.T, np.eye(3), atol=1e-6)
        or np.linalg.det(R) <= 0.0  # an orthogonal R with det -1 is a reflection
    ):
        raise ShapeError(
            f"{name} must be a homogeneous transform [[R, t], [0, 0, 0, 1]] with R a rotation"
        )
    return T
