"""The Wilson score interval of a campaign's success rates (Wilson 1927)."""

from __future__ import annotations

import math

from redservo.errors import ConfigurationError

__all__ = ["Z95", "wilson_interval"]

Z95 = 1.959963984540054
"""The 0.975 quantile of the standard normal distribution (two-sided 95 %)."""


def wilson_interval(successes: int, n: int, *, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (Wilson 1927).

    ``(p̂ + z²/2n ± z sqrt(p̂(1-p̂)/n + z²/4n²)) / (1 + z²/n)`` with ``p̂ = successes/n``.

    Args:
        successes: Number of successes, in [0, n].
        n: Number of trials (>= 0); with n = 0 the interval is [0, 1].
        z: Normal quantile (default: 95 % two-sided).

    Raises:
        ConfigurationError: ``successes`` outside [0, n] or ``n < 0``.
    """
    if n < 0 or not 0 <= successes <= n:
        raise ConfigurationError(f"need 0 <= successes <= n, got successes={successes}, n={n}")
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1.0 + z * z / n
    center = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, center - half), min(1.0, center + half)
