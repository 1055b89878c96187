"""The validated inputs of one law call (:class:`LawInputs`, :func:`validate_inputs`).

Every law's :meth:`~redservo.redundancy.Law.__call__` checks its arguments here once: shapes,
finiteness, real values, gains, and that ``q`` lies within the limits; units as in
:mod:`redservo.redundancy.base`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, _to_float, require_finite
from redservo.errors import ConfigurationError, JointLimitError, ShapeError
from redservo.kernels import lazy
from redservo.limits import JointLimits
from redservo.redundancy.gain import AdaptiveGain, gain_value
from redservo.redundancy.packs import limits_pack

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import inputs as _K
else:
    _K = lazy("inputs")
_F64 = np.dtype(np.float64)
_EMPTY = np.empty(0)

__all__ = ["LawInputs", "validate_inputs"]


class LawInputs(NamedTuple):
    """Validated inputs of one control step (internal to the laws)."""

    J1: FloatArray
    e1: FloatArray
    q: FloatArray
    limits: JointLimits
    lam: float
    dt: float
    de1_dt: FloatArray | None
    secondary: FloatArray | None
    qdot_prev: FloatArray | None = None

    @property
    def e_eff(self) -> FloatArray:
        """Effective error ``e1 + ∂e1/∂t / λ`` (feed-forward folded in, CM01 eq. 2)."""
        if self.de1_dt is None:
            return self.e1
        return self.e1 + self.de1_dt / self.lam


def _vec(value: ArrayLike, name: str, size: int) -> FloatArray:
    arr = (
        value
        if isinstance(value, np.ndarray) and value.dtype == np.float64
        else _to_float(value, name)
    )
    if arr.shape != (size,):
        raise ShapeError(f"{name} must have shape ({size},), got shape {arr.shape}", argument=name)
    return arr


def _scalar(value: object, name: str, meaning: str) -> float:
    """Return a finite positive float, or raise ConfigurationError naming ``name``."""
    if type(value) is float and 0.0 < value < math.inf:
        return value
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise ConfigurationError(
            f"{name} ({meaning}) must be a finite positive number, got {value!r}", argument=name
        )
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ConfigurationError(
            f"{name} ({meaning}) must be a finite positive number, got {value!r}", argument=name
        )
    return v


def _real_matrix(J1: ArrayLike) -> FloatArray:
    if isinstance(J1, np.ndarray) and J1.dtype == np.float64:
        return J1
    if np.iscomplexobj(J1):
        raise ShapeError("J1 must be a real matrix, got complex values", argument="J1")
    return _to_float(J1, "J1")


_LAM = "λ, 1/s"
_DT = "control period, s"


def _array(a: object, shape: tuple[int, ...]) -> bool:
    """``a`` is a C-contiguous float64 array of shape ``shape``."""
    if type(a) is not np.ndarray:
        return False
    return a.dtype == _F64 and a.shape == shape and bool(a.flags.c_contiguous)


def _fast(
    J1: object,
    e1: object,
    q: object,
    limits: object,
    de1_dt: object,
    secondary: object,
    qdot_prev: object,
) -> bool:
    """True when the inputs are valid by the kernel's conservative test (module of
    :func:`validate_inputs`); False sends them through the full checks."""
    if type(J1) is not np.ndarray or J1.ndim != 2 or type(limits) is not JointLimits:
        return False
    m, n = J1.shape
    if m == 0 or limits.n != n or not _array(J1, (m, n)):
        return False
    if not (_array(e1, (m,)) and _array(q, (n,))):
        return False
    opt: list[object] = []
    for value, size in ((de1_dt, m), (secondary, n), (qdot_prev, n)):
        if value is None:
            opt.append(_EMPTY)
        elif _array(value, (size,)):
            opt.append(value)
        else:
            return False
    return bool(_K.inputs_ok(J1, e1, q, limits_pack(limits).rows, *opt))


def validate_inputs(
    *,
    J1: ArrayLike,
    e1: ArrayLike,
    q: ArrayLike,
    limits: JointLimits,
    lam: float | AdaptiveGain,
    dt: float,
    de1_dt: ArrayLike | None,
    secondary: ArrayLike | None,
    qdot_prev: ArrayLike | None = None,
) -> LawInputs:
    """Check shapes, finiteness, gains and that ``q`` lies within ``limits``.

    An :class:`~redservo.redundancy.gain.AdaptiveGain` is evaluated at ``‖e1‖∞`` here, so
    that the laws always see a number. Contiguous float64 arrays of the right shapes are
    checked by one kernel (:func:`redservo.kernels.inputs.inputs_ok`); anything it does not
    pass goes through the full checks below, which name the faulty argument.
    """
    if _fast(J1, e1, q, limits, de1_dt, secondary, qdot_prev):  # the arrays are checked
        e = cast(FloatArray, e1)
        return LawInputs(
            cast(FloatArray, J1),
            e,
            cast(FloatArray, q),
            limits,
            gain_value(lam, e) if isinstance(lam, AdaptiveGain) else _scalar(lam, "lam", _LAM),
            _scalar(dt, "dt", _DT),
            cast("FloatArray | None", de1_dt),
            cast("FloatArray | None", secondary),
            cast("FloatArray | None", qdot_prev),
        )
    J = _real_matrix(J1)
    if J.ndim != 2 or J.shape[0] == 0:
        raise ShapeError(
            f"J1 must be a 2-D (m, n) array with m >= 1, got shape {J.shape}", argument="J1"
        )
    m, n = J.shape
    if not isinstance(limits, JointLimits):
        raise ShapeError(
            f"limits must be a redservo.JointLimits, got {type(limits).__name__}; "
            "build one with JointLimits(q_min, q_max, rho=0.1)",
            argument="limits",
        )
    if limits.n != n:
        raise ShapeError(f"limits has {limits.n} joints but J1 has {n} columns", argument="limits")
    for name, value in (("e1", e1), ("q", q), ("de1_dt", de1_dt), ("secondary", secondary)):
        if value is not None and np.iscomplexobj(value):
            raise ShapeError(f"{name} must be real, got complex values", argument=name)
    e = _vec(e1, "e1", m)
    qa = _vec(q, "q", n)
    ff = None if de1_dt is None else _vec(de1_dt, "de1_dt", m)
    sec = None if secondary is None else _vec(secondary, "secondary", n)
    prev = None if qdot_prev is None else _vec(qdot_prev, "qdot_prev", n)
    require_finite(J1=J, e1=e, q=qa, de1_dt=ff, secondary=sec, qdot_prev=prev)
    if float(np.minimum(qa - limits.q_min, limits.q_max - qa).min()) < -1e-9:
        limits.check(qa)  # the same test: raises JointLimitError naming the joint
        raise JointLimitError("q is outside the joint limits", argument="q")  # pragma: no cover
    if isinstance(lam, AdaptiveGain):
        lam_f = gain_value(lam, e)
    else:
        lam_f = _scalar(lam, "lam", _LAM)
    dt_f = _scalar(dt, "dt", _DT)
    return LawInputs(J, e, qa, limits, lam_f, dt_f, ff, sec, prev)
