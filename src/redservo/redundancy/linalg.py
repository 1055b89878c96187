"""One SVD of the main-task Jacobian serves the pseudo-inverse and the null-space basis.

``J1 = U diag(σ) V^T``. With ``r`` the numerical rank (``σ_i > rcond·σ_max``):

* ``J1^+ = V_r diag(1/σ_r) U_r^T`` (n x m), the Moore-Penrose pseudo-inverse;
* ``E = V[:, r:]`` (n x (n - r)), an **orthonormal** basis of ``Ker J1``
  (literature.md §D.1: CM01's minimal-norm property holds in joint space only
  with an orthonormal E);
* ``J1^⊥ = I - J1^+ J1 = E E^T``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.linalg import lapack

from redservo._validation import FloatArray

__all__ = ["DEFAULT_RCOND", "TaskSVD", "pinv", "task_svd"]

DEFAULT_RCOND = 1e-8
"""Singular values below ``rcond * σ_max`` count as zero (rank loss)."""


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

    def null_projector(self) -> FloatArray:
        """Return the (n, n) orthogonal projector ``J^⊥ = E E^T`` onto ``Ker J``."""
        return np.asarray(self.null @ self.null.T)


def task_svd(J: FloatArray, rcond: float = DEFAULT_RCOND) -> TaskSVD:
    """Decompose ``J`` (m x n) once; see the module docstring.

    Args:
        J: (m, n) task Jacobian, finite.
        rcond: Relative threshold on the singular values for the numerical rank.
    """
    m, n = J.shape
    # LAPACK's dgesvd directly: a third of numpy.linalg.svd's cost on these small matrices.
    info = 1
    if J.size:
        U, sigma, Vt, info = lapack.dgesvd(J, full_matrices=1)
    if info != 0:  # no convergence (or empty input): numpy's driver as a fallback
        U, sigma, Vt = np.linalg.svd(J, full_matrices=True)
    smax = sigma[0] if sigma.size else 0.0
    rank = int(np.count_nonzero(sigma > rcond * smax)) if smax > 0.0 else 0
    V = Vt.T
    if rank:
        pinv = (V[:, :rank] / sigma[:rank]) @ U[:, :rank].T
    else:
        pinv = np.zeros((n, m))
    return TaskSVD(U, sigma, V, rank, pinv, V[:, rank:])


def pinv(A: FloatArray, rcond: float = DEFAULT_RCOND) -> FloatArray:
    """Moore-Penrose pseudo-inverse of a small matrix with a relative singular-value cut-off."""
    if A.size == 0:
        return np.zeros((A.shape[1], A.shape[0]))
    return task_svd(A, rcond).pinv
