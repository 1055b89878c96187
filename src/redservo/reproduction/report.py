"""``report.md``, ``report.json`` and the console summary of ``redservo reproduce``.

The headline counts **paper claims** only; implementation checks (properties that hold by
construction, :mod:`redservo.reproduction.checks`) are reported separately. With a
robustness sweep every claim also shows the fraction of perturbed set-ups in which it
holds, with its 95 % Wilson interval, and the report sorts the claims into robust,
fragile and not reproduced (:mod:`redservo.reproduction.robustness`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from redservo.reproduction.base import ExperimentSpec, Runs
from redservo.reproduction.checks import IMPL, PAPER, Claim
from redservo.reproduction.perturbation import (
    DEPTH_SCALE,
    NOISE_PX,
    PERIODS,
    START_SHIFT,
    START_TURN_DEG,
    TARGET_SHIFT,
    TARGET_TURN_DEG,
)
from redservo.reproduction.robustness import ROBUST_FRACTION, CheckRobustness, Robustness

__all__ = ["ExperimentResult", "console_summary", "markdown", "to_json"]


@dataclass
class ExperimentResult:
    """What one experiment produced on its nominal set-up."""

    spec: ExperimentSpec
    runs: Runs
    claims: list[Claim]
    figures: list[Path]


ImageVerdicts = Mapping[tuple[str, str], bool] | None
"""Per (experiment id, claim name), whether the claim holds through rendered images."""


def fmt(v: Any) -> str:
    """A value of the evidence, short."""
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list | tuple) and v and isinstance(v[0], float):
        return "[" + ", ".join(f"{x:.3g}" for x in v) + "]"
    return str(v)


def _pct(x: float) -> str:
    return f"{100.0 * x:.0f} %"


def _robust_text(r: CheckRobustness | None) -> str:
    if r is None:
        return ""
    lo, hi = r.interval
    return f"{r.holds}/{r.n} ({_pct(r.fraction)}, 95 % CI {_pct(lo)}–{_pct(hi)})"


def _periods(r: CheckRobustness) -> str:
    parts = [
        f"{k} ms: {v[0]}/{v[1]}" if k != "nominal" else f"nominal dt: {v[0]}/{v[1]}"
        for k, v in sorted(r.by_period.items())
    ]
    return "; ".join(parts)


def _counts(results: Sequence[ExperimentResult]) -> dict[str, tuple[int, int]]:
    out: dict[str, tuple[int, int]] = {}
    for kind in (PAPER, IMPL):
        claims = [c for e in results for c in e.claims if c.kind == kind]
        out[kind] = (sum(c.reproduced for c in claims), len(claims))
    return out


def _headline(results: Sequence[ExperimentResult], rob: Robustness | None) -> list[str]:
    counts = _counts(results)
    (p_ok, p_all), (i_ok, i_all) = counts[PAPER], counts[IMPL]
    lines = [
        f"**{p_ok} of {p_all} paper claims reproduced** on the nominal set-ups "
        f"({i_ok} of {i_all} implementation checks hold; they are tests of the code, not "
        "reproductions, and are not counted above).",
        "",
    ]
    if rob is not None:
        cats = rob.by_category(PAPER)
        lines += [
            f"**Robustness** over {rob.n} perturbed set-ups per experiment: "
            f"{len(cats['robust'])} paper claims robust (hold in ≥ {_pct(ROBUST_FRACTION)} of "
            f"the set-ups), {len(cats['fragile'])} fragile, {len(cats['not reproduced'])} not "
            "reproduced (see [Robustness](#robustness)).",
            "",
        ]
    return lines


def _image_text(ok: bool | None) -> str:
    return "—" if ok is None else ("holds" if ok else "**fails**")


def _summary_table(
    results: Sequence[ExperimentResult], rob: Robustness | None, image: ImageVerdicts = None
) -> list[str]:
    head = (
        "| experiment | paper claim | nominal |"
        + (" through images |" if image is not None else "")
        + (" robustness |" if rob else "")
    )
    sep = "|---|---|---|" + ("---|" if image is not None else "") + ("---|" if rob else "")
    lines = ["## Paper claims at a glance", "", head, sep]
    for e in results:
        for c in e.claims:
            if c.kind != PAPER:
                continue
            mark = "reproduced" if c.reproduced else "**not reproduced**"
            row = f"| `{e.spec.id}` | {c.claim} | {mark} |"
            if image is not None:
                row += f" {_image_text(image.get((e.spec.id, c.name)))} |"
            if rob is not None:
                r = rob.get(e.spec.id, c.name)
                row += f" {r.category + ': ' + _robust_text(r) if r else '—'} |"
            lines.append(row)
    return [*lines, ""]


def _robustness_section(rob: Robustness) -> list[str]:
    noise = (
        f"features measured in a rendered image with Gaussian noise of σ ∈ [{NOISE_PX[0]:g}, "
        f"{NOISE_PX[1]:g}] gray levels (`redservo.vision.ImageSensor`, true depth)"
        if rob.pixel_noise
        else "no pixel noise: the image sensor needs OpenCV (`pip install 'redservo[vision]'`), "
        "which is not installed, so the features are ideal"
    )
    period = (
        "each experiment keeps its quick period (`--fast`)"
        if rob.fast
        else f"period {' or '.join(f'{p * 1e3:.0f} ms' for p in PERIODS)} (λ kept)"
    )
    lines = [
        '<a id="robustness"></a>',
        "## Robustness",
        "",
        f"Each experiment was re-run on {rob.n} perturbed set-ups (seed {rob.seed}; "
        f"{rob.workers} worker process(es), {rob.seconds:.0f} s wall time): target moved by "
        f"±{TARGET_SHIFT * 100:g} cm and turned by ±{TARGET_TURN_DEG:g}° per axis, start "
        f"±{START_TURN_DEG:g}° per revolute joint and ±{START_SHIFT * 100:g} cm per prismatic "
        f"joint, {period}, depth error ×{DEPTH_SCALE[0]:g} to ×{DEPTH_SCALE[1]:g} "
        f"(log-uniform), {noise}. A claim is **robust** when it holds on the nominal set-up "
        f"and in at least {_pct(ROBUST_FRACTION)} of the perturbed ones, **fragile** when it "
        "holds nominally but less often, **not reproduced** when it does not hold nominally. "
        "Intervals are 95 % Wilson intervals (docs/formulas.md §12.8). Definitions: "
        "`src/redservo/reproduction/perturbation.py`.",
        "",
    ]
    failed = [s for s in rob.setups if s.error]
    if failed:
        lines += [f"{len(failed)} set-up(s) could not be run (counted as failures):", ""]
        lines += [f"- `{s.experiment}` #{s.index}: {s.error}" for s in failed]
        lines.append("")
    for kind, title in ((PAPER, "Paper claims"), (IMPL, "Implementation checks")):
        lines += [f"### {title}", ""]
        for cat, members in rob.by_category(kind).items():
            lines.append(f"**{cat.capitalize()}** ({len(members)})")
            lines.append("")
            for r in members:
                lines.append(f"- `{r.experiment}` {r.text} — {_robust_text(r)}; {_periods(r)}.")
            lines.append("")
    return lines


def _claim_line(c: Claim, rob: Robustness | None, exp_id: str, image: ImageVerdicts = None) -> str:
    mark = (
        ("reproduced" if c.reproduced else "**not reproduced**")
        if c.kind == PAPER
        else ("holds" if c.reproduced else "**fails**")
    )
    ev = ", ".join(f"{k} = {fmt(v)}" for k, v in c.evidence.items())
    src = f" ({c.source})" if c.source else ""
    line = f"- {c.claim}{src} — {mark}."
    if image is not None:
        line += f" Through images: {_image_text(image.get((exp_id, c.name)))}."
    if rob is not None:
        r = rob.get(exp_id, c.name)
        if r is not None:
            line += f" Robustness: {r.category}, {_robust_text(r)}."
    line += f" Evidence: {ev}."
    return line + (f" {c.note}" if c.note else "")


def _section(
    e: ExperimentResult, rob: Robustness | None, out: Path, image: ImageVerdicts = None
) -> str:
    from redservo.report import summary_table

    spec = e.spec
    rows = {label: r.summary for label, r in e.runs.results.items()}
    lines = [
        f"## {spec.title}",
        "",
        f"*{spec.paper}* — scenario `{spec.scenario}` (`redservo run {spec.scenario}`), "
        f"experiment id `{spec.id}`.",
        "",
    ]
    if spec.notes:
        lines += [spec.notes, ""]
    lines += [summary_table(rows), ""]
    for kind, title in ((PAPER, "Paper claims"), (IMPL, "Implementation checks")):
        mine = [c for c in e.claims if c.kind == kind]
        if mine:
            lines += [f"### {title}", ""]
            lines += [_claim_line(c, rob, spec.id, image) for c in mine]
            lines.append("")
    if spec.extra is not None:
        lines += [spec.extra(e.runs), ""]
    if e.figures:
        lines += ["### Figures", ""]
        lines += [f"![{p.stem}]({p.relative_to(out).as_posix()})" for p in e.figures]
    return "\n".join(lines) + "\n"


def markdown(
    results: Sequence[ExperimentResult],
    rob: Robustness | None,
    out: Path,
    *,
    command: str,
    image: ImageVerdicts = None,
) -> str:
    """The whole ``report.md``; ``image`` holds the verdicts of every claim when the
    experiments were also run through rendered images (``redservo reproduce --sensor image``)."""
    md = [
        "# redservo: reproduction of Chaumette & Marchand 2001 and Mansard & Chaumette 2005",
        "",
        f"Generated by `{command}`. Every verdict below is computed from the simulation logs "
        "by code (`src/redservo/reproduction/`). Paper claims are what the papers report; "
        "implementation checks hold by construction of the laws, the simulator or the chosen "
        "set-up and are listed apart. In the claims and figures axes are numbered from 1 as in "
        "the papers (axis k is joint k − 1); the run tables name joints from 0, like the rest of "
        "redservo. Formulas: docs/formulas.md.",
        "",
        *_headline(results, rob),
        *_summary_table(results, rob, image),
    ]
    if image is not None:
        md += [
            "## Through images",
            "",
            "Every experiment was also run with its features measured in the rendered camera "
            "image (`redservo.vision.ImageSensor`: dots, ellipse, limbs detected in pixels; "
            "image noise σ = 0.5 gray levels; the true depth, so that only the measurement "
            "differs). The column *through images* says whether each claim still holds with "
            "measured features.",
            "",
        ]
    if rob is not None:
        md += _robustness_section(rob)
    md += [_section(e, rob, out, image) for e in results]
    return "\n".join(md)


def to_json(
    results: Sequence[ExperimentResult],
    rob: Robustness | None,
    out: Path,
    *,
    fast: bool,
    image: ImageVerdicts = None,
) -> dict[str, Any]:
    """The content of ``report.json``."""
    counts = _counts(results)
    report: dict[str, Any] = {
        "fast": fast,
        "paper_claims": {"reproduced": counts[PAPER][0], "total": counts[PAPER][1]},
        "implementation_checks": {"hold": counts[IMPL][0], "total": counts[IMPL][1]},
        "experiments": [],
    }
    for e in results:
        report["experiments"].append(
            {
                "id": e.spec.id,
                "title": e.spec.title,
                "paper": e.spec.paper,
                "scenario": e.spec.scenario,
                "runs": {label: r.summary.to_dict() for label, r in e.runs.results.items()},
                "claims": [c.to_dict() for c in e.claims],
                "figures": [p.relative_to(out).as_posix() for p in e.figures],
            }
        )
    if rob is not None:
        report["robustness"] = rob.to_dict()
    if image is not None:
        report["through_images"] = {f"{k[0]}/{k[1]}": v for k, v in image.items()}
    return report


def console_summary(report: dict[str, Any], out: Path) -> list[str]:
    """Lines for the terminal: the headline, every paper claim not reproduced, with a
    robustness sweep every paper claim that is not robust, and where the report is."""
    pc, ic = report["paper_claims"], report["implementation_checks"]
    lines = [
        f"reproduced {pc['reproduced']}/{pc['total']} paper claims "
        f"({ic['hold']}/{ic['total']} implementation checks hold)"
    ]
    claims = [(e["id"], c) for e in report["experiments"] for c in e["claims"]]
    failed = [(i, c) for i, c in claims if not c["reproduced"]]
    for kind, title in ((PAPER, "not reproduced"), (IMPL, "implementation checks failing")):
        mine = [(i, c) for i, c in failed if c["kind"] == kind]
        if mine:
            lines.append(f"{title} ({len(mine)}):")
            lines += [f"  - [{i}] {' '.join(str(c['claim']).split())}" for i, c in mine]
    rob = report.get("robustness")
    if rob is not None:
        paper = [c for c in rob["checks"] if c["kind"] == PAPER]
        cats = {k: [c for c in paper if c["category"] == k] for k in ("robust", "fragile")}
        n_not = len(paper) - len(cats["robust"]) - len(cats["fragile"])
        lines.append(
            f"robustness over {rob['n']} perturbed set-ups per experiment "
            f"({rob['seconds']:.0f} s, {rob['workers']} worker(s)): {len(cats['robust'])} robust, "
            f"{len(cats['fragile'])} fragile, {n_not} not reproduced"
        )
        weak = [c for c in paper if c["category"] != "robust"]
        if weak:
            lines.append(f"not robust ({len(weak)}):")
            lines += [
                f"  - [{c['experiment']}] {' '.join(str(c['claim']).split())} — "
                f"{c['category']}, holds in {c['holds']}/{c['n']}"
                for c in weak
            ]
    lines.append(f"details, evidence and figures: {out / 'report.md'} (and report.json)")
    return lines
