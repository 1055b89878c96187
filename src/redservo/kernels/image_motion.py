"""The camera-motion limit's speed of the fastest image point in one compiled call
(:mod:`redservo.control.image_motion`, whose module docstring gives the limit).

``ṡ = L (J q̇)`` by BLAS (``np.dot``, as numpy's ``@`` on the Python path), then the
largest ``hypot(ṡ_x, ṡ_y)`` over the image points' rows, NaN as soon as one is NaN (as
``np.max`` gives it). Units: normalized image units per second.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel

__all__ = ["fastest_point"]


@kernel
def fastest_point(L: Any, J: Any, qdot: Any, rows: Any) -> float:
    """The largest image speed of the points whose ``x`` rows of ``L`` (k, 6) are
    ``rows`` (int64, at least one) under the command ``qdot`` (n,) with the robot Jacobian
    ``J`` (6, n); -1 when a row is not one of ``L``'s (the caller's numpy code then says
    which)."""
    sdot = np.dot(L, np.dot(J, qdot))
    for i in range(rows.shape[0]):
        if rows[i] < 0 or rows[i] + 1 >= sdot.shape[0]:
            return -1.0
    best = -np.inf
    for i in range(rows.shape[0]):
        r = rows[i]
        h = np.hypot(sdot[r], sdot[r + 1])
        if np.isnan(h):
            return h
        if h > best:
            best = h
    return best
