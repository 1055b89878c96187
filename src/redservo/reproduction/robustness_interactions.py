"""What the failures of a claim have in common, found by the sweep itself.

For a claim that is not robust, the all-factors set-ups of the robustness sweep
(:mod:`redservo.reproduction.robustness`) are split by each factor's value at the threshold
that separates its failures best (the smallest two-sided Fisher exact p-value, at least
``MIN_SIDE`` set-ups on each side), and the two best factors are crossed: how many set-ups
fail when both are on their bad side, and how many of the others. The report prints these
lines under the robustness tables, so the explanation of a fragility is computed from the
run, not written by hand.

The thresholds are chosen on the same set-ups they are tested on and the p-values are not
corrected for the factors and thresholds tried: they rank the candidates, they do not
prove an effect (N = 20 set-ups make every split exploratory).

Factor values (from each set-up's ``Perturbation``): target shift ‖Δt‖ (cm), target turn
‖θu‖ (deg), start: largest joint offset (fraction of its half-width), period (ms), depth
``Ẑ/Z``, noise σ (gray levels), blur σ (px), focal ``f_true/f``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["MIN_SIDE", "Split", "best_splits", "interaction_text"]

MIN_SIDE = 3
"""Fewest set-ups on each side of a threshold."""

_VALUES: dict[str, tuple[Callable[[Mapping[str, Any]], float | None], str, str]] = {
    "target shift": (lambda p: 100.0 * math.hypot(*p["target_shift"]), "{:.1f} cm", ""),
    "target turn": (lambda p: math.hypot(*p["target_turn_deg"]), "{:.1f}°", ""),
    "start": (lambda p: max(abs(v) for v in p["start_offsets"]), "{:.2f}", " of its half-width"),
    "period": (lambda p: None if p["period"] is None else 1e3 * p["period"], "{:.0f} ms", ""),
    "depth": (lambda p: p["depth_scale"], "×{:.2f}", ""),
    "noise": (lambda p: p["noise_px"], "σ {:.1f}", " gray levels"),
    "blur": (lambda p: p["blur_px"], "{:.2f} px", ""),
    "focal": (lambda p: p["focal_scale"], "×{:.3f}", ""),
}
"""Per factor: its scalar value in a ``Perturbation.to_dict()``, the value's format, a suffix."""


@dataclass(frozen=True)
class Split:
    """One factor's best threshold.

    Attributes:
        factor: The factor.
        threshold: The value between the two sides (midpoint of two set-ups' values).
        above: Whether the bad side (more failures) is at or above ``threshold``.
        bad: (failures, set-ups) on the bad side.
        good: (failures, set-ups) on the other side.
        p: Two-sided Fisher exact p-value of the 2×2 table (uncorrected).
        members: Indices (into the set-ups given) on the bad side.
    """

    factor: str
    threshold: float
    above: bool
    bad: tuple[int, int]
    good: tuple[int, int]
    p: float
    members: frozenset[int]

    def side(self) -> str:
        """The bad side in words, e.g. ``depth ≥ ×1.31``."""
        fmt, suffix = _VALUES[self.factor][1], _VALUES[self.factor][2]
        return f"{self.factor} {'≥' if self.above else '<'} {fmt.format(self.threshold)}{suffix}"


def _values(setups: Sequence[Mapping[str, Any]], factor: str) -> list[float] | None:
    get = _VALUES[factor][0]
    out = []
    for s in setups:
        try:
            v = get(s["perturbation"]) if s.get("perturbation") else None
        except (KeyError, TypeError, ValueError):  # a set-up that does not draw this factor
            v = None
        if v is None:
            return None
        out.append(float(v))
    return out


def _split(factor: str, x: Sequence[float], fail: Sequence[bool]) -> Split | None:
    from scipy.stats import fisher_exact

    levels = sorted(set(x))
    best: Split | None = None
    for lo, hi in itertools.pairwise(levels):
        t = 0.5 * (lo + hi)
        up = [i for i, v in enumerate(x) if v >= t]
        down = [i for i, v in enumerate(x) if v < t]
        if min(len(up), len(down)) < MIN_SIDE:
            continue
        fu, fd = sum(fail[i] for i in up), sum(fail[i] for i in down)
        table = [[fu, len(up) - fu], [fd, len(down) - fd]]
        p = float(fisher_exact(table).pvalue)
        above = fu / len(up) >= fd / len(down)
        bad, good = (up, down) if above else (down, up)
        cand = Split(
            factor,
            t,
            above,
            (sum(fail[i] for i in bad), len(bad)),
            (sum(fail[i] for i in good), len(good)),
            p,
            frozenset(bad),
        )
        if best is None or cand.p < best.p:
            best = cand
    return best


def best_splits(setups: Sequence[Mapping[str, Any]], check: str) -> list[Split]:
    """Every factor's best split of the set-ups by ``check``'s failures, smallest p first.

    Args:
        setups: The all-factors set-ups of one experiment (``SetupResult.__dict__``: its
            ``perturbation`` and ``verdicts``).
        check: The check's name.
    """
    fail = [not s.get("verdicts", {}).get(check, False) for s in setups]
    if not any(fail) or all(fail):
        return []
    out = []
    for factor in _VALUES:
        x = _values(setups, factor)
        if x is None or len(set(x)) < 2:
            continue
        s = _split(factor, x, fail)
        if s is not None:
            out.append(s)
    return sorted(out, key=lambda s: (s.p, s.factor))


def interaction_text(setups: Sequence[Mapping[str, Any]], check: str) -> str:
    """One markdown sentence: the two factors that split ``check``'s failures best, and their
    crossing (module docstring); "" when it never or always fails."""
    splits = best_splits(setups, check)
    if not splits:
        return ""
    fail = [not s.get("verdicts", {}).get(check, False) for s in setups]
    total = sum(fail)
    parts = [
        f"{s.side()}: {s.bad[0]} of {s.bad[1]} fail, {s.good[0]} of {s.good[1]} otherwise "
        f"(p = {s.p:.2g})"
        for s in splits[:2]
    ]
    text = f"{total} of {len(fail)} all-factors set-ups fail; " + "; ".join(parts)
    if len(splits) >= 2:
        a, b = splits[0], splits[1]
        both = a.members & b.members
        k = sum(fail[i] for i in both)
        rest = len(fail) - len(both)
        text += (
            f". Both ({a.side()} and {b.side()}): {k} of {len(both)} fail, "
            f"{total - k} of {rest} otherwise"
        )
    return text + " (thresholds chosen on these set-ups, p uncorrected: exploratory)."
