"""Small input-validation helpers shared by the package (internal)."""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo.errors import ShapeError

FloatArray = NDArray[np.float64]


_FLOAT64 = np.dtype(np.float64)

_NUMERIC_KINDS = "fiu"
"""numpy dtype kinds accepted as numbers: floats, signed and unsigned integers."""

_KIND_NAMES = {
    "U": "strings",
    "S": "bytes",
    "b": "booleans",
    "c": "complex numbers",
    "M": "dates",
    "m": "time differences",
    "O": "Python objects that are not all numbers",
    "V": "raw records",
}


def is_number(x: object) -> bool:
    """A real number that is not a boolean (``numbers.Real``: int, float, numpy scalars)."""
    return isinstance(x, numbers.Real) and not isinstance(x, bool | np.bool_)


def _to_float(value: ArrayLike, name: str) -> FloatArray:
    """``value`` as a float64 array; only numbers (floats or integers) are accepted.

    Strings (``["0.1", "0.2"]``, which numpy would parse), booleans, complex numbers and
    other objects raise :class:`ShapeError` naming ``name``, so that a mistyped input is
    reported instead of converted.
    """
    if type(value) is np.ndarray and value.dtype == np.float64:
        return value  # hot path: already a float array
    try:
        raw = np.asarray(value)
        kind = raw.dtype.kind
        if kind == "O" and all(is_number(x) for x in raw.flat):
            raw = np.asarray(value, dtype=float)  # e.g. Python ints too large for int64
            kind = "f"
    except (TypeError, ValueError):
        raise ShapeError(
            f"{name} must be numeric and rectangular (a list or array of numbers), got {value!r}",
            argument=name,
        ) from None
    if kind not in _NUMERIC_KINDS:
        what = _KIND_NAMES.get(kind, f"values of type {raw.dtype}")
        raise ShapeError(
            f"{name} must hold numbers (floats or integers), got {what}: {value!r}",
            argument=name,
        )
    return np.asarray(raw, dtype=np.float64)


def is_float_vector(a: object, n: int) -> bool:
    """``a`` is a C-contiguous float64 array of shape (n,), as a compiled kernel takes it
    without a copy (a check of the type and layout only: the kernel checks the values)."""
    return (
        type(a) is np.ndarray and a.dtype == _FLOAT64 and a.shape == (n,) and a.flags.c_contiguous
    )


def as_time(value: object, name: str) -> float:
    """Return ``value`` as a finite time stamp (s), raising :class:`ShapeError` otherwise.

    Only real numbers are stamps: a string (``"1.0"``), a boolean (``True``), NaN or inf is
    refused, never converted, so that a mistyped stamp is reported instead of taken as time.
    """
    if type(value) is float and -math.inf < value < math.inf:
        return value  # hot path: a finite Python float
    if not is_number(value) or not np.isfinite(float(value)):  # type: ignore[arg-type]
        raise ShapeError(
            f"{name} must be a finite number of seconds, got {value!r} ({type(value).__name__})",
            argument=name,
        )
    return float(value)  # type: ignore[arg-type]


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
        raise ShapeError(f"{name} must have shape {want}, got shape {arr.shape}", argument=name)
    # One summed check (a sum of finite floats overflows only near 1e308); precise on failure.
    if not math.isfinite(float(arr.sum())) and not np.isfinite(arr).all():
        raise ShapeError(f"{name} must be finite (no NaN or inf), got {arr}", argument=name)
    return arr


def require_finite(**arrays: FloatArray | None) -> None:
    """Raise ShapeError naming the first array holding NaN or inf, or whose sum overflows.

    One summed check on the hot path: a sum of finite numbers can only be non-finite by
    overflow (|values| ~ 1e308). Then each array is looked at alone: one with entries so
    large that its own sum overflows is reported by name; finite arrays whose sums only
    overflow together are valid inputs.
    """
    total = 0.0
    for arr in arrays.values():
        if arr is not None:
            total += float(arr.sum())
    if math.isfinite(total):
        return
    for name, arr in arrays.items():
        if arr is not None and not np.isfinite(arr).all():
            raise ShapeError(f"{name} must be finite (no NaN or inf), got {arr}", argument=name)
    with np.errstate(over="ignore"):
        big = [n for n, a in arrays.items() if a is not None and not math.isfinite(a.sum())]
    if big:
        raise ShapeError(
            f"{' and '.join(big)} too large: the sum of the entries of {big[0]} overflows "
            "float64 (|values| near 1e308); rescale the task",
            argument=big[0],
        )


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
        raise ShapeError(f"{name} must have shape ({r}, {c}), got shape {arr.shape}", argument=name)
    if not np.all(np.isfinite(arr)):
        raise ShapeError(f"{name} must be finite (no NaN or inf)", argument=name)
    return arr


def as_transform(value: ArrayLike, name: str) -> FloatArray:
    """Return ``value`` as a 4x4 homogeneous transform with a proper rotation block.

    Checks: shape (4, 4), finite, bottom row ``(0, 0, 0, 1)`` (to 1e-9), ``R R^T = I``
    (to 1e-6 per entry) and ``det R > 0`` (not a reflection). Written on Python floats:
    it runs on the control hot path, where ``np.allclose`` would dominate the step.
    """
    if type(value) is np.ndarray and value.shape == (4, 4) and value.dtype == _FLOAT64:
        # Fast path (the same checks on one flat list, no call per test): a valid transform
        # is returned here, anything else gets the checks below and their messages.
        a, b, c, x, d, e, f, y, g, h, i, z, p, q, r, w = value.ravel().tolist()
        if (
            math.isfinite(a + b + c + d + e + f + g + h + i + x + y + z + p + q + r + w)
            and -1e-9 <= p <= 1e-9
            and -1e-9 <= q <= 1e-9
            and -1e-9 <= r <= 1e-9
            and -1e-9 <= w - 1.0 <= 1e-9
            and -1e-6 <= a * a + b * b + c * c - 1.0 <= 1e-6
            and -1e-6 <= d * d + e * e + f * f - 1.0 <= 1e-6
            and -1e-6 <= g * g + h * h + i * i - 1.0 <= 1e-6
            and -1e-6 <= a * d + b * e + c * f <= 1e-6
            and -1e-6 <= a * g + b * h + c * i <= 1e-6
            and -1e-6 <= d * g + e * h + f * i <= 1e-6
            and a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0.0
        ):
            return value
    T = (
        value
        if isinstance(value, np.ndarray) and value.dtype == np.float64
        else _to_float(value, name)
    )
    if T.shape != (4, 4):
        raise ShapeError(f"{name} must have shape (4, 4), got shape {T.shape}", argument=name)
    (a, b, c, x), (d, e, f, y), (g, h, i, z), (p, q, r, w) = T.tolist()
    if not math.isfinite(a + b + c + d + e + f + g + h + i + x + y + z + p + q + r + w):
        raise ShapeError(f"{name} must be finite (no NaN or inf)", argument=name)
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
            f"{name} must be a homogeneous transform [[R, t], [0, 0, 0, 1]] with R a rotation",
            argument=name,
        )
    return T
