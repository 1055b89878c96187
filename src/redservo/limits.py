"""Joint limits, activation thresholds and the joint-limit cost of Chaumette & Marchand 2001.

All positions are in joint units: metres for prismatic axes, radians for
revolute ones. Equation numbers refer to Chaumette & Marchand 2001 (CM01) unless
stated; MC05 eqs. 28-29 define the same cost.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray, as_vector
from redservo.errors import ConfigurationError, JointLimitError

__all__ = ["JointLimits"]


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Real joint limits ``q̄`` and activation thresholds ``q̃`` (CM01 eq. 3).

    ``q̃_min = q̄_min + rho Δq̄`` and ``q̃_max = q̄_max - rho Δq̄`` with
    ``Δq̄_i = q̄_max,i - q̄_min,i`` per axis (CM01 prints Δq̄ without the index;
    literature.md §D.3 item 6). ``rho = 0.1`` puts the thresholds at ±0.9 in
    normalized coordinates.

    Args:
        q_min: (n,) lower limits ``q̄_min`` (m or rad).
        q_max: (n,) upper limits ``q̄_max`` (m or rad), each strictly above ``q_min``.
        rho: Width of the critical band as a fraction of the range, in (0, 1/2).
    """

    q_min: FloatArray
    q_max: FloatArray
    rho: float = 0.1
    range: FloatArray = field(init=False, repr=False)
    q_tilde_min: FloatArray = field(init=False, repr=False)
    q_tilde_max: FloatArray = field(init=False, repr=False)
    _center: FloatArray = field(init=False, repr=False)

    def __init__(self, q_min: ArrayLike, q_max: ArrayLike, rho: float = 0.1) -> None:
        lo = as_vector(q_min, "q_min")
        hi = as_vector(q_max, "q_max", lo.shape[0])
        if lo.shape[0] == 0:
            raise JointLimitError("q_min and q_max must have at least one joint")
        bad = np.flatnonzero(~(hi > lo))
        if bad.size:
            i = int(bad[0])
            raise JointLimitError(
                f"q_max must be strictly greater than q_min for every joint; joint {i} has "
                f"q_min={lo[i]:.6g}, q_max={hi[i]:.6g}"
            )
        rho_f = float(rho)
        if not (0.0 < rho_f < 0.5):
            raise ConfigurationError(f"rho must lie in (0, 0.5), got {rho!r}")
        rng = hi - lo
        for name, value in (
            ("q_min", lo),
            ("q_max", hi),
            ("range", rng),
            ("q_tilde_min", lo + rho_f * rng),
            ("q_tilde_max", hi - rho_f * rng),
            ("_center", 0.5 * (lo + hi)),
        ):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "rho", rho_f)

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q_min.shape[0])

    @property
    def center(self) -> FloatArray:
        """(n,) mid-range configuration ``(q̄_min + q̄_max)/2``."""
        return 0.5 * (self.q_min + self.q_max)

    def with_rho(self, rho: float) -> JointLimits:
        """Return a copy with another band width ``rho``."""
        return JointLimits(self.q_min, self.q_max, rho)

    # -- validation ---------------------------------------------------------------------------

    def check(self, q: ArrayLike, name: str = "q", *, tol: float = 1e-9) -> FloatArray:
        """Return ``q`` as an array, raising if its shape is wrong or it lies outside the limits.

        Args:
            q: (n,) joint configuration.
            name: Argument name for the message.
            tol: Allowed excess beyond a limit, in joint units.

        Raises:
            ShapeError: ``q`` is not a finite (n,) vector.
            JointLimitError: some ``q_i`` is outside ``[q̄_min,i - tol, q̄_max,i + tol]``.
        """
        qa = as_vector(q, name, self.n)
        out = np.flatnonzero((qa < self.q_min - tol) | (qa > self.q_max + tol))
        if out.size:
            i = int(out[0])
            raise JointLimitError(
                f"{name}[{i}] = {qa[i]:.6g} is outside the joint limits "
                f"[{self.q_min[i]:.6g}, {self.q_max[i]:.6g}]; "
                f"{out.size} joint(s) out of range: {out.tolist()}"
            )
        return qa

    def contains(self, q: ArrayLike) -> bool:
        """True when every joint of ``q`` lies within ``[q̄_min, q̄_max]``."""
        qa = np.asarray(q, dtype=float)
        return bool(np.all((qa >= self.q_min) & (qa <= self.q_max)))

    # -- geometry -----------------------------------------------------------------------------

    def normalized(self, q: ArrayLike) -> FloatArray:
        """Return ``2 (q - center) / range``: -1 at ``q̄_min``, +1 at ``q̄_max``, ±(1-2 rho) at ``q̃``."""
        return 2.0 * (np.asarray(q, dtype=float) - self.center) / self.range

    def distance(self, q: ArrayLike) -> FloatArray:
        """Return (n,) the distance to the nearest real limit, ``min(q - q̄_min, q̄_max - q)``."""
        qa = np.asarray(q, dtype=float)
        return np.minimum(qa - self.q_min, self.q_max - qa)

    def margin(self, q: ArrayLike) -> FloatArray:
        """Return (n,) the distance to the nearest limit as a fraction of the range (0 at a limit, 0.5 at mid-range)."""
        return self.distance(q) / self.range

    def in_band(self, q: ArrayLike) -> FloatArray:
        """Return (n,) booleans: axis between its threshold ``q̃`` and its real limit (or beyond)."""
        qa = np.asarray(q, dtype=float)
        return np.asarray((qa <= self.q_tilde_min) | (qa >= self.q_tilde_max))

    # -- cost (CM01 eqs. 4-6, MC05 eqs. 28-29) --------------------------------------------------

    def excess(self, q: ArrayLike) -> FloatArray:
        """Return (n,) ``s_i`` of CM01 eq. 5: signed excess beyond the threshold, 0 inside."""
        qa = np.asarray(q, dtype=float)
        return np.where(
            qa > self.q_tilde_max,
            qa - self.q_tilde_max,
            np.where(qa < self.q_tilde_min, qa - self.q_tilde_min, 0.0),
        )

    def cost(self, q: ArrayLike) -> float:
        """Return the joint-limit cost ``h_s = 1/2 Σ s_i² / Δq̄_i`` (CM01 eq. 4), in joint units."""
        s = self.excess(q)
        return float(0.5 * np.sum(s * s / self.range))

    def gradient(self, q: ArrayLike) -> FloatArray:
        """Return ``e2 = (∂h_s/∂q)^T`` (n,), ``e2_i = s_i / Δq̄_i`` (CM01 eq. 6); dimensionless."""
        return self.excess(q) / self.range

    # -- the iterative scheme's helpers (CM01 eqs. 8 and 17) ------------------------------------

    def gamma(self, q_hat: ArrayLike) -> FloatArray:
        """Return (n,) the smoothing gains ``γ_k`` of CM01 eq. 17 (corrected), in [0, 1].

        ``γ = 0`` between the thresholds, rising linearly to 1 at the real limit
        (literature.md §D.3 item 4 fixes the printed third case), clamped to 1
        beyond it. ``γ = 1`` everywhere is the basic scheme.

        Args:
            q_hat: (n,) predicted configuration ``q̂(t+1)`` (CM01 eq. 8).
        """
        qh = np.asarray(q_hat, dtype=float)
        g = np.maximum(self.q_tilde_min - qh, qh - self.q_tilde_max)
        g /= self.rho * self.range
        np.minimum(g, 1.0, out=g)
        return np.maximum(g, 0.0, out=g)

    def critical(self, q: ArrayLike, q_hat: ArrayLike) -> FloatArray:
        """Return (n,) booleans: the axes that are *critical* (literature.md §D.3 item 9).

        Axis k is critical when its predicted position ``q̂_k`` lies in the band
        ``[q̄_min, q̃_min] ∪ [q̃_max, q̄_max]`` (or beyond the real limit) and it moves
        toward the nearest real limit, ``dist(q̂_k) < dist(q_k)``.

        Args:
            q: (n,) current configuration.
            q_hat: (n,) predicted configuration.
        """
        qa = np.asarray(q, dtype=float)
        qh = np.asarray(q_hat, dtype=float)
        # In the band: max(q̂ - q̃_max, q̃_min - q̂) >= 0 (only one can be, as q̃_min < q̃_max).
        # Toward the nearest limit: (q̂ - q) has the sign of (q̂ - centre) (upper or lower band).
        in_band = np.maximum(qh - self.q_tilde_max, self.q_tilde_min - qh) >= 0.0
        toward = (qh - qa) * (qh - self._center) > 0.0
        return np.asarray(in_band & toward)
