"""One SVD of the main-task Jacobian serves the pseudo-inverse and the null-space basis.

``J1 = U diag(σ) V^T``. With ``r`` the numerical rank (``σ_i > rcond·σ_max``):

* ``J1^+ = V_r diag(1/σ_r) U_r^T`` (n x m), the Moore-Penrose pseudo-inverse;
* ``E = V[:, r:]`` (n x (n - r)), an **orthonormal** basis of ``Ker J1``
  (docs/formulas.md §7.1: CM01's minimal-norm property holds in joint space only
  with an orthonormal E);
* ``J1^⊥ = I - J1^+ J1 = E E^T``.

**Robust inverse** (docs/safety.md; the ``robust`` option of the laws). With a
filter threshold ``ε`` (relative), singular values ``σ_i < ε σ_max`` are inverted as
``σ_i / (ε σ_max)²`` instead of ``1/σ_i``: singular-value filtering with a linear
ramp, continuous at the threshold, so that ``‖J1_f⁺‖ <= 1/(ε σ_max)`` whatever the
conditioning (the amplification of ``e1`` is bounded by ``1/ε`` relative to the
best-conditioned direction). Directions above the threshold are inverted exactly, so a
well-conditioned ``J1`` (``σ_min >= ε σ_max``) gets the exact pseudo-inverse. The rank,
and so the null-space basis E, are unchanged.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import lazy

__all__ = [
    "DEFAULT_RCOND",
    "ROBUST_FILTER",
    "TaskSVD",
    "filtered_reciprocal",
    "pinv",
    "task_svd",
]

DEFAULT_RCOND = 1e-8
"""Singular values below ``rcond * σ_max`` count as zero (rank loss)."""
ROBUST_FILTER = 1e-3
"""Relative threshold ε of the robust task inverse: the amplification is at most ``1/ε``."""

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import linalg as _K
else:
    _K = lazy("linalg")


def filtered_reciprocal(sigma: FloatArray, threshold: float) -> FloatArray:
    """Return ``1/σ`` for ``σ >= threshold`` and ``σ/threshold²`` below (bounded by 1/threshold)."""
    s = np.ascontiguousarray(sigma, dtype=np.float64)
    return np.asarray(_K.filtered_reciprocal(s.ravel(), float(threshold))).reshape(s.shape)


class TaskSVD(NamedTuple):
    """The SVD of a task Jacobian and what the laws derive from it."""

    U: FloatArray
    """(m, m) left singular vectors."""
    sigma: FloatArray
    """(min(m, n),) singular values, descending."""
    V: FloatArray
    """(n, n) right singular vectors as columns."""
    rank: int
    """Numerical rank r."""
    pinv: FloatArray
    """(n, m) pseudo-inverse ``J^+`` (rank-r truncated)."""
    null: FloatArray
    """(n, n - r) orthonormal basis E of ``Ker J``."""
    filtered: int = 0
    """How many nonzero singular values the robust inverse filtered (0: exact ``J^+``)."""

    def null_projector(self) -> FloatArray:
        """Return the (n, n) orthogonal projector ``J^⊥ = E E^T`` onto ``Ker J``."""
        return np.asarray(self.null @ self.null.T)


def task_svd(J: FloatArray, rcond: float = DEFAULT_RCOND, robust: float = 0.0) -> TaskSVD:
    """Decompose ``J`` (m x n) once; see the module docstring.

    LAPACK's ``dgesvd`` is called by the kernel :func:`redservo.kernels.linalg.task_svd`
    (no numpy wrapper: on these small matrices it costs more than the decomposition).

    Args:
        J: (m, n) task Jacobian, finite.
        rcond: Relative threshold on the singular values for the numerical rank.
        robust: Relative filter threshold ε of the robust inverse, 0 for the exact ``J^+``.
    """
    A = np.ascontiguousarray(J, dtype=np.float64)
    U, sigma, V, rank, pinv_, filtered = _K.task_svd(A, float(rcond), float(robust))
    return TaskSVD(U, sigma, V, int(rank), pinv_, V[:, rank:], int(filtered))


def pinv(A: FloatArray, rcond: float = DEFAULT_RCOND) -> FloatArray:
    """Moore-Penrose pseudo-inverse of a small matrix with a relative singular-value cut-off."""
    if A.size == 0:
        return np.zeros((A.shape[1], A.shape[0]))
    return task_svd(A, rcond).pinv
