"""``report.md``, ``report.json`` and the console summary of ``redservo reproduce``.

The headline counts **distinct paper statements** (a statement checked in several variants
counts once); implementation and set-up checks (:mod:`redservo.reproduction.checks`) are
reported separately. With a robustness sweep every claim also shows, per perturbed factor,
the fraction of set-ups in which it holds with its 95 % Wilson interval, and the report sorts
the claims into robust, inconclusive, fragile and not reproduced on the interval
(:mod:`redservo.reproduction.robustness`, :mod:`redservo.reproduction.report_robustness`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from redservo.reproduction.base import ExperimentSpec, Runs
from redservo.reproduction.checks import IMPL, PAPER, Claim
from redservo.reproduction.claims_table import claim_lines
from redservo.reproduction.imaging import REALISTIC
from redservo.reproduction.report_robustness import pct, robust_text, robustness_section
from redservo.reproduction.robustness_tally import CATEGORIES, ROBUST_LEVEL, Robustness

__all__ = ["ExperimentResult", "console_summary", "markdown", "statements", "to_json"]


@dataclass
class ExperimentResult:
    """What one experiment produced on its nominal set-up."""

    spec: ExperimentSpec
    runs: Runs
    claims: list[Claim]
    figures: list[Path]
    image_runs: Runs | None = None


ImageVerdicts = Mapping[tuple[str, str], bool] | None
"""Per (experiment id, claim name), whether the claim holds through rendered images."""


def fmt(v: Any) -> str:
    """A value of the evidence, short."""
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list | tuple) and v and isinstance(v[0], float):
        return "[" + ", ".join(f"{x:.3g}" for x in v) + "]"
    return str(v)


def _counts(results: Sequence[ExperimentResult]) -> dict[str, tuple[int, int]]:
    out: dict[str, tuple[int, int]] = {}
    for kind in (PAPER, IMPL):
        claims = [c for e in results for c in e.claims if c.kind == kind]
        out[kind] = (sum(c.reproduced for c in claims), len(claims))
    return out


def statements(results: Sequence[ExperimentResult]) -> dict[tuple[str, str], list[bool]]:
    """The distinct paper statements: ``{(experiment, statement): [verdict per variant]}``.

    A claim of a variant experiment (``ExperimentSpec.variant_of``) or restating another check
    (``Check.statement``) is the same statement as the one it restates.
    """
    out: dict[tuple[str, str], list[bool]] = {}
    for e in results:
        for c in e.claims:
            if c.kind == PAPER:
                key = (e.spec.variant_of or e.spec.id, c.statement or c.name)
                out.setdefault(key, []).append(bool(c.reproduced))
    return out


def _headline(results: Sequence[ExperimentResult], rob: Robustness | None) -> list[str]:
    counts = _counts(results)
    (p_ok, p_all), (i_ok, i_all) = counts[PAPER], counts[IMPL]
    st = statements(results)
    every = sum(all(v) for v in st.values())
    some = sum(any(v) for v in st.values())
    lines = [
        f"**{every} of {len(st)} distinct paper statements reproduced** on the nominal set-ups "
        f"(in every variant that checks them; {some} of {len(st)} in at least one). Counting "
        f"each variant apart (two critical-axis rules of gpm-auto, MC05 §V-A on two starts): "
        f"{p_ok} of {p_all} paper-claim checks hold. {i_ok} of {i_all} implementation and "
        "set-up checks hold; they test the code, the equations' consequences and the chosen "
        "set-up, not the papers, and are not counted above.",
        "",
    ]
    if rob is not None:
        cats = rob.by_category(PAPER)
        lines += [
            f"**Robustness**, per paper-claim check: the set-ups of {rob.n} perturbed with all "
            "factors together where it holds, its 95 % Wilson interval, then its category "
            f"(robust: lower bound ≥ {pct(ROBUST_LEVEL)}; fragile: upper bound < "
            f"{pct(ROBUST_LEVEL)}; inconclusive in between; see [Robustness](#robustness))"
            + (
                f", and its rate over {rob.unfiltered} set-ups drawn without the phenomenon "
                "filter that chose the nominal one"
                if rob.unfiltered
                else ""
            )
            + ":",
            "",
            *[f"- {line}" for line in claim_lines(rob.to_dict())],
            "",
            f"In all: {len(cats['robust'])} robust, {len(cats['inconclusive'])} inconclusive, "
            f"{len(cats['fragile'])} fragile, {len(cats['not reproduced'])} not reproduced.",
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
                row += f" {robust_text(r) + ' — ' + r.category if r else '—'} |"
            lines.append(row)
    return [*lines, ""]


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
            line += f" Robustness: {robust_text(r)}, {r.category}."
    line += f" Evidence: {ev}."
    return line + (f" {c.note}" if c.note else "")


def _section(
    e: ExperimentResult, rob: Robustness | None, out: Path, image: ImageVerdicts = None
) -> str:
    from redservo.runs.tables import summary_table

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
        if e.image_runs is not None:
            lines += ["### Through images", "", spec.extra(e.image_runs), ""]
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
            "Every experiment, the cross-comparison included, was also run with its features "
            "measured in a rendered camera image by the library's detector "
            "(`redservo.vision.ImageSensor`: dots, ellipse, limbs detected in pixels; the true "
            f"depth, so that only the measurement differs), made realistic: {REALISTIC.describe()} "
            "(`redservo.reproduction.imaging.REALISTIC`). The column *through images* says "
            "whether each claim still holds with measured features; each experiment's section "
            "lists its implementation checks through images too. Those that test the "
            "equations' exact arithmetic on the features (‖e1‖ falling by (1 − λ dt) at every "
            "step, iteration counts to the tolerance, rates fitted down to 1e-4 of the start "
            "error) can fail there: the pixels' quantization (the first two, even in a "
            "noise-free image) and noise (the third) move the measured features by more than "
            "the margins they test (docs/results.md).",
            "",
        ]
    if rob is not None:
        md += robustness_section(rob, [(e.spec.id, e.spec.fragility) for e in results])
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
    st = statements(results)
    report: dict[str, Any] = {
        "fast": fast,
        "paper_statements": {
            "reproduced": sum(all(v) for v in st.values()),
            "reproduced_in_some_variant": sum(any(v) for v in st.values()),
            "total": len(st),
        },
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
        report["imaging"] = REALISTIC.to_dict()
    return report


def console_summary(report: dict[str, Any], out: Path) -> list[str]:
    """Lines for the terminal: the headline, every paper claim not reproduced, with a
    robustness sweep every paper claim's k/N and 95 % interval before its category, and
    where the report is."""
    ps, pc, ic = report["paper_statements"], report["paper_claims"], report["implementation_checks"]
    lines = [
        f"reproduced {ps['reproduced']}/{ps['total']} distinct paper statements "
        f"({pc['reproduced']}/{pc['total']} paper-claim checks with variants; "
        f"{ic['hold']}/{ic['total']} implementation and set-up checks hold)"
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
        cats = {k: [c for c in paper if c["category"] == k] for k in CATEGORIES}
        lines.append(
            f"robustness over {rob['n']} perturbed set-ups per experiment and factor "
            f"({rob['seconds']:.0f} s, {rob['workers']} worker(s)); per paper claim, set-ups "
            "where it holds with all factors (95 % Wilson interval), then its category:"
        )
        lines += [f"  - {line}" for line in claim_lines(rob)]
        lines.append("in all: " + ", ".join(f"{len(v)} {k}" for k, v in cats.items()))
    lines.append(f"details, evidence and figures: {out / 'report.md'} (and report.json)")
    return lines
