"""The robustness part of ``report.md``: the per-factor table of every claim, the categories
decided on the Wilson interval and the factors that break each claim
(:mod:`redservo.reproduction.robustness`)."""

from __future__ import annotations

from collections.abc import Sequence

from redservo.reproduction.checks import IMPL, PAPER
from redservo.reproduction.perturbation import (
    BLUR_PX,
    DEPTH_SCALE,
    FOCAL_ERROR,
    NOISE_PX,
    PERIODS,
    START_SHIFT,
    START_TURN_DEG,
    TARGET_SHIFT,
    TARGET_TURN_DEG,
)
from redservo.reproduction.robustness_interactions import interaction_text
from redservo.reproduction.robustness_tally import ROBUST_LEVEL, CheckRobustness, Robustness
from redservo.reproduction.unfiltered import START_SHIFT as UNF_SHIFT
from redservo.reproduction.unfiltered import START_TURN_DEG as UNF_TURN
from redservo.reproduction.unfiltered import TARGET_SHIFT as UNF_TARGET
from redservo.reproduction.unfiltered import TARGET_TURN_DEG as UNF_TARGET_TURN

__all__ = ["factor_text", "pct", "robust_text", "robustness_section"]


def pct(x: float) -> str:
    """A fraction as a whole percentage."""
    return f"{100.0 * x:.0f} %"


def robust_text(r: CheckRobustness | None, factor: str = "all") -> str:
    """``k/n (p %, 95 % CI lo–hi)`` of one factor (default: all together)."""
    if r is None or factor not in r.by_factor:
        return ""
    k, n = r.by_factor[factor]
    lo, hi = r.interval_of(factor)
    return f"{k}/{n} ({pct(k / n if n else 0.0)}, 95 % CI {pct(lo)}–{pct(hi)})"


def factor_text(r: CheckRobustness) -> str:
    """Which single factor breaks the claim, or the weakest one."""
    if r.breaking:
        return "broken by " + ", ".join(
            f"{f} ({r.by_factor[f][0]}/{r.by_factor[f][1]})" for f in r.breaking
        )
    w = r.weakest
    if w is None:
        return "no single factor makes it fail"
    k, n = r.by_factor[w]
    return f"no single factor breaks it; weakest: {w} ({k}/{n})"


def _ranges(rob: Robustness) -> str:
    period = (
        "each experiment keeps its quick period (`--fast`), so the period is not swept"
        if rob.fast
        else f"**period** {' or '.join(f'{p * 1e3:.0f} ms' for p in PERIODS)} (λ kept)"
    )
    image = (
        f"**noise**: features measured in a rendered image with Gaussian noise of σ ∈ "
        f"[{NOISE_PX[0]:g}, {NOISE_PX[1]:g}] gray levels; **blur**: the same image blurred "
        f"with σ ∈ [{BLUR_PX[0]:g}, {BLUR_PX[1]:g}] px; **focal**: the same image drawn by a "
        f"camera whose focal length is off by up to ±{FOCAL_ERROR * 100:g} % (uncalibrated; "
        "the detector and the controller keep the assumed one) — all with the library's "
        "detector and the true depth"
        if rob.pixel_noise
        else "no image factor (`--no-pixel-noise`, or OpenCV is not installed: `pip install "
        "'redservo[vision]'`), so the features are ideal"
    )
    return (
        f"**target shift** ±{TARGET_SHIFT * 100:g} cm per axis; **target turn** "
        f"±{TARGET_TURN_DEG:g}° per axis; **start** ±{START_TURN_DEG:g}° per revolute and "
        f"±{START_SHIFT * 100:g} cm per prismatic joint; {period}; **depth** error "
        f"×{DEPTH_SCALE[0]:g} to ×{DEPTH_SCALE[1]:g} (log-uniform); {image}"
    )


def _table(rob: Robustness, kind: str) -> list[str]:
    rows = [c for c in rob.checks if c.kind == kind]
    if not rows:
        return []
    head = "| experiment | claim | nominal | " + " | ".join(rob.factors) + " | category |"
    lines = [head, "|---" * (len(rob.factors) + 4) + "|"]
    for r in rows:
        cells = []
        for f in rob.factors:
            k, n = r.by_factor.get(f, (0, 0))
            broken = f != "all" and f in r.breaking
            cells.append(f"**{k}/{n}**" if broken else f"{k}/{n}")
        nominal = {True: "holds", False: "fails", None: "—"}[r.nominal]
        lines.append(
            f"| `{r.experiment}` | {r.text} | {nominal} | "
            + " | ".join(cells)
            + f" | {r.category} |"
        )
    return [*lines, ""]


def robustness_section(rob: Robustness, notes: Sequence[tuple[str, str]] = ()) -> list[str]:
    """The ``## Robustness`` section of ``report.md``; ``notes`` are ``(experiment id,
    markdown)`` explanations of what breaks the fragile claims (``ExperimentSpec.fragility``)."""
    lines = [
        '<a id="robustness"></a>',
        "## Robustness",
        "",
        f"Each experiment was re-run on {rob.n} perturbed set-ups **per factor**, each factor "
        f"alone (the others nominal) and all together (seed {rob.seed}; {rob.workers} worker "
        f"process(es), {rob.seconds:.0f} s wall time). Factors: {_ranges(rob)}. Set-up i of a "
        "single factor uses the value that set-up i of *all* combines with the others.",
        "",
        "Categories are decided on the 95 % Wilson interval of the *all* column, not on its "
        f"point estimate: **robust** when its lower bound is ≥ {pct(ROBUST_LEVEL)}, **fragile** "
        f"when its upper bound is < {pct(ROBUST_LEVEL)}, **inconclusive** in between (more "
        "set-ups needed), **not reproduced** when the claim fails on the nominal set-up. A "
        f"single factor **breaks** a claim when its own interval lies below {pct(ROBUST_LEVEL)} "
        "(bold in the tables). Intervals: docs/formulas.md §12.8; definitions: "
        "`src/redservo/reproduction/perturbation.py`.",
        "",
    ]
    if rob.unfiltered:
        lines += [
            f"The column *unfiltered* counts {rob.unfiltered} set-ups per experiment drawn "
            "without the filter that chose the nominal set-up for the papers' phenomena (start "
            f"±{UNF_TURN:g}° per revolute, ±{UNF_SHIFT * 100:g} cm per prismatic joint, "
            f"targets ±{UNF_TARGET * 100:g} cm and ±{UNF_TARGET_TURN:g}°, ideal sensor, "
            "nominal period and depth; `src/redservo/reproduction/unfiltered.py`): a claim that "
            "holds nominally but rarely there was partly selected into the reproduction.",
            "",
        ]
    failed = [s for s in rob.setups if s.error]
    if failed:
        lines += [f"{len(failed)} set-up(s) could not be run (counted as failures):", ""]
        lines += [f"- `{s.experiment}` {s.factor} #{s.index}: {s.error}" for s in failed]
        lines.append("")
    for kind, title in ((PAPER, "Paper claims"), (IMPL, "Implementation checks")):
        lines += [f"### {title}, per factor", "", *_table(rob, kind)]
    lines += ["### Paper claims that are not robust, and what breaks them", ""]
    weak = [c for c in rob.checks if c.kind == PAPER and c.category != "robust"]
    for r in weak:
        rows = [
            s.__dict__ for s in rob.setups if s.experiment == r.experiment and s.factor == "all"
        ]
        shared = interaction_text(rows, r.name)
        lines.append(
            f"- `{r.experiment}` {r.text} — all factors {robust_text(r)}, {r.category}; "
            f"{factor_text(r)}." + (f" What its failures share: {shared}" if shared else "")
        )
    if not weak:
        lines.append("Every paper claim is robust.")
    lines.append("")
    swept = {c.experiment for c in rob.checks}
    mine = [(i, text) for i, text in notes if text and i in swept]
    if mine:
        lines += ["### Whose fragility: the method's or our set-up's", ""]
        for exp_id, text in mine:
            lines += [f"**`{exp_id}`.** {text}", ""]
    return lines
