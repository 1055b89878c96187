"""The robots' check of the joint positions in compiled code (the kinematics' hot path).

:func:`redservo.robots.dh.check_q_named` (the Afma6, DH chains, URDF and MJCF chains) on a
C-contiguous float64 (n,) array first runs :func:`joints_inside`; the Afma6's kinematics
runs :func:`afma6_checked`, the same test and the kinematics in one call. The test accepts
only what every Python check accepts: each joint within ``[q̄_min,i, q̄_max,i]`` (so
finite), or with ``check_limits`` False each joint finite. Anything else (a joint within
the 1e-9 tolerance past a limit included) goes through the Python check, which accepts it
or raises the one error naming the joint. Units: joint units (m or rad).
"""

from __future__ import annotations

import math
from typing import Any

from redservo.kernels._jit import COMPILED, kernel
from redservo.kernels.kinematics import afma6_kinematics

__all__ = ["COMPILED", "afma6_checked", "joints_inside"]


@kernel
def joints_inside(q: Any, q_min: Any, q_max: Any, check_limits: bool) -> bool:
    """Every ``q_i`` within ``[q̄_min,i, q̄_max,i]`` (NaN and ±inf fail the comparisons);
    with ``check_limits`` False, every ``q_i`` finite."""
    for i in range(q.shape[0]):
        v = q[i]
        if check_limits:
            if not (q_min[i] <= v and v <= q_max[i]):
                return False
        elif not math.isfinite(v):
            return False
    return True


@kernel
def afma6_checked(
    q: Any,
    q_min: Any,
    q_max: Any,
    check_limits: bool,
    eMc: Any,
    cVe: Any,
    coupling: float,
    offset: float,
    out: Any,
) -> bool:
    """:func:`joints_inside`, then when it holds the Afma6's
    :func:`~redservo.kernels.kinematics.afma6_kinematics` written into the caller's float64
    arrays ``out`` = ``(bMc, J)`` ((4, 4), (6, 6); cheaper than returning two new arrays,
    which numba boxes at ≈ 0.4 µs apiece); True when the test held, False (``out`` not
    written) when it did not."""
    if not joints_inside(q, q_min, q_max, check_limits):
        return False
    bMc, J = afma6_kinematics(q, eMc, cVe, coupling, offset)
    bMc_out, J_out = out
    bMc_out[:, :] = bMc
    J_out[:, :] = J
    return True
