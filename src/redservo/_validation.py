"""Small input-validation helpers shared by the package (internal)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo.errors import ShapeError

FloatArray = NDArray[np.float64]


def _to_float(value: ArrayLike, name: str) -> FloatArray:
    if type(value) is np.ndarray and value.dtype == np.float64:
        return value  # hot path: already a float array
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
    # One summed check (a sum of finite floats overflows only near 1e308); precise on failure.
    if not math.isfinite(float(arr.sum())) and not np.isfinite(arr).all():
        raise ShapeError(f"{name} must be finite (no NaN or inf), got {arr}")
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
    """Return ``value`` as a 4x4 homogeneous transform with a proper rotation block.

    Checks: shape (4, 4), finite, bottom row ``(0, 0, 0, 1)`` (to 1e-9), ``R R^T = I``
    (to 1e-6 per entry) and ``det R > 0`` (not a reflection). Written on Python floats:
    it runs on the control hot path, where ``np.allclose`` would dominate the step.
    """
    T = (
        value
        if isinstance(value, np.ndarray) and value.dtype == np.float64
        else _to_float(value, name)
    )
    if T.shape != (4, 4):
        raise ShapeError(f"{name} must have shape (4, 4), got shape {T.shape}")
    (a, b, c, x), (d, e, f, y), (g, h, i, z), (p, q, r, w) = T.tolist()
    if not math.isfinite(a + b + c + d + e + f + g + h + i + x + y + z + p + q + r + w):
        raise ShapeError(f"{name} must be finite (no NaN or inf)")
    ok = abs(p) <= 1e-9 and abs(q) <= 1e-9 and abs(r) <= 1e-9 and abs(w - 1.0) <= 1e-9
    if ok:
        # Rows of R orthonormal, and a positive determinant (a reflection has det -1).
        ok = (
            abs(a * a + b * b + c * c - 1.0) <= 1e-6
            and abs(d * d + e * e + f * f - 1.0) <= 1e-6
            and abs(g * g + h * h + i * i - 1.0) <= 1e-6
            and abs(a * d + b * e + c * f) <= 1e-6
            and abs(a * g + b * h + c * i) <= 1e-6
            and abs(d * g + e * h + f * i) <= 1e-6
            and a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0.0
        )
    if not ok:
        raise ShapeError(
            f"{name} must be a homogeneous transform [[R, t], [0, 0, 0, 1]] with R a rotation"
        )
    return T
