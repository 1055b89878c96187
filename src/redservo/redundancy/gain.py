"""An adaptive gain λ(‖e‖): small commands for large errors, fast convergence near the goal.

The gain ViSP offers for its visual servos (the facts, not the code)::

    λ(x) = (λ0 - λ∞) exp(-λ'0 x / (λ0 - λ∞)) + λ∞,    x = ‖e1‖∞

so that ``λ(0) = λ0`` (gain at zero error), ``λ(x) → λ∞`` for large errors, and the
slope at zero is ``dλ/dx(0) = -λ'0``. With ``λ0 > λ∞`` a large initial error no longer
means a large initial command, and the exponential decay near the goal is fast. The
error norm is the infinity norm of the task error, as in ViSP. ``λ0 = λ∞`` is a
constant gain. Units: λ in 1/s; λ'0 in 1/s per task unit.

Every law accepts an :class:`AdaptiveGain` wherever it takes ``lam``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError

__all__ = ["AdaptiveGain", "gain_value"]


@dataclass(frozen=True)
class AdaptiveGain:
    """λ(‖e1‖∞) decreasing from ``zero`` (at e1 = 0) to ``inf`` (large errors).

    Attributes:
        zero: λ0 = λ(0) > 0 (1/s).
        inf: λ∞ = lim λ(x), 0 < λ∞ <= λ0 (1/s).
        slope: λ'0 >= 0, minus the slope of λ at 0 (1/s per task unit); 0 gives λ = λ0.
    """

    zero: float
    inf: float
    slope: float

    def __post_init__(self) -> None:
        for name in ("zero", "inf", "slope"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
                raise ConfigurationError(
                    f"AdaptiveGain.{name} must be a number, got {v!r}", argument=name
                )
            if not math.isfinite(float(v)) or float(v) > 1e6:
                raise ConfigurationError(
                    f"AdaptiveGain.{name} must be finite and at most 1e6, got {v!r}",
                    argument=name,
                )
        if not (self.zero > 0.0 and 0.0 < self.inf <= self.zero):
            raise ConfigurationError(
                f"AdaptiveGain needs 0 < inf <= zero (λ∞ <= λ0, 1/s), got zero={self.zero!r}, "
                f"inf={self.inf!r}",
                argument="inf",
            )
        if self.slope < 0.0:
            raise ConfigurationError(
                f"AdaptiveGain.slope must be >= 0, got {self.slope!r}", argument="slope"
            )

    def __call__(self, e_norm: float) -> float:
        """Return λ (1/s) for an error of infinity norm ``e_norm`` (task units)."""
        a = self.zero - self.inf
        if a <= 0.0 or self.slope == 0.0:
            return float(self.zero if self.slope == 0.0 else self.inf)
        return float(a * math.exp(-self.slope * e_norm / a) + self.inf)


def gain_value(lam: float | AdaptiveGain, e1: FloatArray) -> float:
    """Return the gain to use for task error ``e1``: ``lam`` itself, or λ(‖e1‖∞)."""
    if isinstance(lam, AdaptiveGain):
        return lam(float(np.max(np.abs(e1))) if e1.size else 0.0)
    return lam
