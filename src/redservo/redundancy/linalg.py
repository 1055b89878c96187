"""One SVD of the main-task Jacobian serves the pseudo-inverse and the null-space basis.

``J1 = U diag(σ) V^T``. With ``r`` the numerical rank (``σ_i > rcond·σ_max``):

* ``J1^+ = V_r diag(1/σ_r) U_r^T`` (n x m), the Moore-Penrose pseudo-inverse;
* ``E = V[:, r:]`` (n x (n - r)), an **orthonormal** basis of ``Ker J1``
  (literature.md §D.1: CM01's minimal-norm property holds in joint space only
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

from typing import NamedTuple

import numpy as np
from scipy.linalg import lapack

from redservo._validation import FloatArray
from redservo.redundancy.flags import Event, Flag

__all__ = [
    "DEFAULT_RCOND",
    "ROBUST_FILTER",
    "TaskSVD",
    "filtered_reciprocal",
    "pinv",
    "svd_events",
    "task_svd",
]

DEFAULT_RCOND = 1e-8
"""Singular values below ``rcond * σ_max`` count as zero (rank loss)."""
ROBUST_FILTER = 1e-3
"""Relative threshold ε of the robust task inverse: the amplification is at most ``1/ε``."""


def filtered_reciprocal(sigma: FloatArray, threshold: float) -> FloatArray:
    """Return ``1/σ`` for ``σ >= threshold`` and ``σ/threshold²`` below (bounded by 1/threshold)."""
    with np.errstate(divide="ignore"):
        return np.where(sigma >= threshold, 1.0 / sigma, sigma / (threshold * threshold))


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

    Args:
        J: (m, n) task Jacobian, finite.
        rcond: Relative threshold on the singular values for the numerical rank.
        robust: Relative filter threshold ε of the robust inverse, 0 for the exact ``J^+``.
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
    filtered = 0
    if rank:
        inv = 1.0 / sigma[:rank]
        if robust > 0.0 and sigma[rank - 1] < robust * smax:
            inv = filtered_reciprocal(sigma[:rank], robust * smax)
            filtered = int(np.count_nonzero(sigma[:rank] < robust * smax))
        pinv = (V[:, :rank] * inv) @ U[:, :rank].T
    else:
        pinv = np.zeros((n, m))
    return TaskSVD(U, sigma, V, rank, pinv, V[:, rank:], filtered)


def pinv(A: FloatArray, rcond: float = DEFAULT_RCOND) -> FloatArray:
    """Moore-Penrose pseudo-inverse of a small matrix with a relative singular-value cut-off."""
    if A.size == 0:
        return np.zeros((A.shape[1], A.shape[0]))
    return task_svd(A, rcond).pinv


def svd_events(m: int, n: int, svd: TaskSVD, robust: float = 0.0) -> list[Event]:
    """Typed events for a task SVD: rank loss, no redundancy, filtered (damped) directions."""
    events: list[Event] = []
    if svd.rank < m:
        events.append(
            Event(
                Flag.RANK_LOSS,
                m - svd.rank,
                f"J1 rank-deficient (rank {svd.rank} < m = {m}): truncated pseudo-inverse",
            )
        )
    if svd.rank >= n:
        events.append(
            Event(
                Flag.NO_REDUNDANCY, n, "no redundancy (rank J1 = n): reduces to the classical law"
            )
        )
    if svd.filtered:
        cond = float(svd.sigma[0] / svd.sigma[svd.rank - 1])
        events.append(
            Event(
                Flag.DAMPED,
                1.0 / robust,
                f"J1 ill-conditioned (σ_max/σ_min = {cond:.3g}): {svd.filtered} direction(s) "
                f"filtered, amplification bounded by {1.0 / robust:.3g}",
            )
        )
    return events
