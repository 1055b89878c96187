"""The hot-path test of a law call's inputs (:func:`redservo.redundancy.inputs.validate_inputs`).

One kernel call answers "nothing to report" for the common case: every entry finite and
far from overflow, and ``q`` within the limits up to the validation's tolerance. Any other
answer sends the caller to the full checks, which raise the exception naming the argument
(or accept an input this conservative test does not). Units as the law call's.
"""

from __future__ import annotations

import math
from typing import Any

from redservo.kernels._jit import kernel
from redservo.kernels.pack import Q_MAX, Q_MIN

__all__ = ["LIMIT_TOL", "inputs_ok"]

LIMIT_TOL = 1e-9
"""How far (m or rad) ``q`` may lie beyond a limit and still be accepted."""

_BIG = 1e300
"""Entries below this size cannot make a sum overflow (the full check then agrees)."""


@kernel
def _small(a: Any) -> bool:
    """Every entry of the 1-D array ``a`` finite and below ``_BIG`` in size."""
    for i in range(a.shape[0]):
        x = a[i]
        if not (math.isfinite(x) and abs(x) < _BIG):
            return False
    return True


@kernel
def inputs_ok(J1: Any, e1: Any, q: Any, lp: Any, ff: Any, sec: Any, prev: Any) -> bool:
    """True when ``J1`` (m, n), ``e1``, ``q`` and the optional ``ff``, ``sec``, ``prev``
    (empty when absent) hold only finite entries below 1e300 in size, and
    ``min(q - q_min, q_max - q) >= -LIMIT_TOL`` on every joint (``lp`` the packed limits,
    :mod:`redservo.kernels.pack`)."""
    for r in range(J1.shape[0]):
        if not _small(J1[r]):
            return False
    if not (_small(e1) and _small(q) and _small(ff) and _small(sec) and _small(prev)):
        return False
    for i in range(q.shape[0]):
        if min(q[i] - lp[Q_MIN, i], lp[Q_MAX, i] - q[i]) < -LIMIT_TOL:
            return False
    return True
