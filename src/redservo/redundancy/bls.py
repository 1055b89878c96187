"""Solvers of the bounded least squares ``min ‖J x - r‖² + eps ‖x - z‖²``, ``lo <= x <= hi``
(the ``qp`` law, :mod:`redservo.redundancy.qp`; docs/formulas.md §10.5).

The law's default solver is compiled (:mod:`redservo.kernels.boxqp`); these are the
others: a :mod:`qpsolvers` backend by name (optional extra ``redservo[qp]``, imported
lazily; :data:`PREFERRED_QP_SOLVERS` lists the usual ones), ``daqp`` called directly (the
call qpsolvers makes, without its ~20 µs per call), and the fallback. Without a QP
backend, or when it fails, :func:`scipy.optimize.lsq_linear` (``bvls``) on
``[J; √eps I] x ≈ [r; √eps z]``; if that fails too, the unconstrained solution clipped to
the bounds. Each fallback is named in the returned note; nothing here raises.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.redundancy.linalg import DEFAULT_RCOND

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import bls as _K
else:
    _K = lazy("bls")

__all__ = [
    "PREFERRED_QP_SOLVERS",
    "daqp_module",
    "daqp_once",
    "qpsolvers_module",
    "solve_bounded_least_squares",
]

PREFERRED_QP_SOLVERS = ("daqp", "proxsuite", "quadprog")


def qpsolvers_module() -> Any | None:
    """Return the :mod:`qpsolvers` module, or None when the optional extra is not installed."""
    try:
        return importlib.import_module("qpsolvers")
    except ImportError:
        return None


def daqp_module() -> Any | None:
    """The :mod:`daqp` module, or None when it is not installed."""
    try:
        return importlib.import_module("daqp")
    except ImportError:
        return None


def _scipy_solve(
    J: FloatArray, r: FloatArray, z: FloatArray, eps: float, lo: FloatArray, hi: FloatArray
) -> FloatArray:
    n = J.shape[1]
    se = np.sqrt(eps)
    A = np.vstack([J, se * np.eye(n)])
    b = np.concatenate([r, se * z])
    from scipy.optimize import lsq_linear  # heavy import, only when this fallback runs

    res = lsq_linear(A, b, bounds=(lo, hi), method="bvls")
    return np.asarray(res.x, dtype=float)


def _qp_solve(
    qpsolvers: Any,
    solver: str,
    P: FloatArray,
    c: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
) -> FloatArray | None:
    """``min ½ y^T P y + c^T y`` s.t. ``lo <= y <= hi`` with a QP backend (None: failed)."""
    n = P.shape[0]
    if solver == "daqp":  # the call qpsolvers makes, without its per-call overhead (~20 µs)
        daqp = daqp_module()
        if daqp is not None:
            x, _, exitflag, _ = daqp.solve(
                P, c, np.zeros((0, n)), hi, lo, np.zeros(n, dtype=np.intc)
            )
            return np.asarray(x, dtype=float) if exitflag > 0 else None
    x = qpsolvers.solve_qp(P, c, lb=lo, ub=hi, solver=solver)
    if x is None:
        return None
    return np.asarray(x, dtype=float)


def solve_bounded_least_squares(
    J: FloatArray,
    r: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    *,
    eps: float,
    z: FloatArray | None = None,
    solver: str = "scipy",
) -> tuple[FloatArray, str]:
    """Solve ``min ‖J x - r‖² + eps ‖x - z‖²`` s.t. ``lo <= x <= hi``; never raises.

    Variables with ``lo == hi`` (to 1e-12 relative) are fixed and eliminated.

    Args:
        J: (m, n) matrix.
        r: (m,) target.
        lo: (n,) lower bounds, ``lo <= hi``.
        hi: (n,) upper bounds.
        eps: Absolute regularization weight > 0.
        z: (n,) regularization target, default 0.
        solver: ``"scipy"`` or a :mod:`qpsolvers` backend name.

    Returns:
        ``(x, used)``: the (n,) solution, clipped to the bounds, and a note naming
        the solver actually used (and any fallback).
    """
    n = J.shape[1]
    c_ = np.ascontiguousarray
    zz = np.zeros(n) if z is None else c_(z, dtype=np.float64)
    Jc, rc, loc, hic = c_(J, float), c_(r, float), c_(lo, float), c_(hi, float)
    x, free, Jf, rf, zf, lof, hif, P, c = _K.bls_reduce(Jc, rc, loc, hic, zz, float(eps))
    if free.size == 0:
        return np.clip(x, lo, hi), "none (all velocities fixed by their bounds)"
    args = (Jf, rf, zf, eps, lof, hif)
    used = "scipy lsq_linear (bvls)"
    xf: FloatArray | None = None
    if solver != "scipy":
        qps = qpsolvers_module()
        try:
            xf = _qp_solve(qps, solver, P, c, lof, hif) if qps is not None else None
        except Exception as exc:  # a solver failure must not stop the control loop
            used = f"{solver} failed ({type(exc).__name__}); fallback scipy lsq_linear (bvls)"
            xf = None
        else:
            direct = solver == "daqp" and daqp_module() is not None
            name = "daqp" if direct else f"qpsolvers/{solver}"
            used = name if xf is not None else f"{solver} failed; fallback scipy"
    if xf is None or not np.all(np.isfinite(xf)):
        try:
            xf = _scipy_solve(*args)
        except (ValueError, np.linalg.LinAlgError) as exc:
            used = f"{used}; scipy failed ({type(exc).__name__}): unconstrained solution clipped"
            xf = np.linalg.lstsq(
                np.vstack([Jf, np.sqrt(eps) * np.eye(free.size)]),
                np.concatenate([rf, np.sqrt(eps) * zf]),
                rcond=None,
            )[0]
    out, polished = _K.bls_expand(Jc, rc, zz, loc, hic, x, free, c_(xf, float), DEFAULT_RCOND)
    if polished:
        used = f"{used} + active-set polish"
    return out, used


_DAQP: list[Any] = []


def daqp_once() -> Any | None:
    """:func:`daqp_module`, looked up once per process."""
    if not _DAQP:
        _DAQP.append(daqp_module())
    return _DAQP[0]
