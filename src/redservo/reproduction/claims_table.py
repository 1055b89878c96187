"""Per-claim robustness numbers, written from a sweep's ``report.json`` (never by hand).

``report.md``, the console summary and docs/results.md give every claim its count of set-ups
``k/N`` and 95 % Wilson interval *before* its category, so that "inconclusive" (which at
N = 20 spans 10/20 to 17/20) never hides how often a claim failed. The docs table is
regenerated from one full run::

    redservo reproduce --robustness 20 --unfiltered 20 --out out
    python -m redservo.reproduction.claims_table out/report.json --doc docs/results.md

(or, from two runs, ``redservo reproduce --robustness 20 --out out`` and ``redservo reproduce
--unfiltered 20 --out out-unfiltered``, then ``... out/report.json --unfiltered
out-unfiltered/report.json --doc docs/results.md``), which replaces the block between ``BEGIN``/``END`` markers (:data:`BEGIN`, :data:`END`) of the
document. ``--trim FILE`` writes the part of ``report.json`` the tables are made from (the
checks, and the all-factors set-ups), small enough to commit:
the tests compare the docs' block with what it generates.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from redservo.errors import ConfigurationError
from redservo.reproduction.robustness_interactions import interaction_text
from redservo.reproduction.unfiltered import FACTOR as UNFILTERED

__all__ = [
    "BEGIN",
    "END",
    "claim_lines",
    "doc_block",
    "load_robustness",
    "main",
    "merge_unfiltered",
    "rate_text",
    "replace_block",
    "trim",
]

BEGIN = "<!-- BEGIN claims_table (generated: do not edit) -->"
END = "<!-- END claims_table -->"
PAPER = "paper claim"


def _pct(x: float) -> str:
    return f"{100.0 * x:.0f} %"


def rate_text(c: Mapping[str, Any], factor: str = "all") -> str:
    """``k/N (95 % CI lo–hi %)`` of one check's column, or "—" when not swept."""
    col = c.get("by_factor", {}).get(factor)
    if not col or not col["n"]:
        return "—"
    lo, hi = col["interval"]
    return f"{col['holds']}/{col['n']} (95 % CI {_pct(lo)}–{_pct(hi)})"


def _category(c: Mapping[str, Any]) -> str:
    return str(c["category"]) if "all" in c.get("by_factor", {}) else "—"


def _why(c: Mapping[str, Any]) -> str:
    cols = c.get("by_factor", {})
    if c.get("broken_by"):
        return "broken by " + ", ".join(
            f"{f} ({cols[f]['holds']}/{cols[f]['n']})" for f in c["broken_by"]
        )
    w = c.get("weakest_factor")
    return f"weakest: {w} ({cols[w]['holds']}/{cols[w]['n']})" if w else "—"


def claim_lines(rob: Mapping[str, Any], kind: str = PAPER) -> list[str]:
    """One console line per check of ``kind``, numbers first: ``k/N (CI) category [id]
    claim``, with its unfiltered rate when drawn."""
    out = []
    for c in rob["checks"]:
        if c["kind"] != kind:
            continue
        unf = rate_text(c, UNFILTERED)
        out.append(
            f"{rate_text(c)} {_category(c)}"
            + (f", unfiltered {unf}" if unf != "—" else "")
            + f" [{c['experiment']}] {' '.join(str(c['claim']).split())}"
        )
    return out


def _setups(rob: Mapping[str, Any], experiment: str) -> list[Mapping[str, Any]]:
    return [
        s for s in rob.get("setups", []) if s["experiment"] == experiment and s["factor"] == "all"
    ]


def _table(rob: Mapping[str, Any], kind: str) -> list[str]:
    lines = [
        "| all factors: k/N (95 % CI) | category | unfiltered: k/N (95 % CI) | nominal "
        "| experiment | claim | breaking or weakest factor (alone) |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in rob["checks"]:
        if c["kind"] != kind:
            continue
        nominal = {True: "holds", False: "fails", None: "—"}[c["nominal"]]
        lines.append(
            f"| {rate_text(c)} | {_category(c)} | {rate_text(c, UNFILTERED)} | {nominal} "
            f"| `{c['experiment']}` | {' '.join(str(c['claim']).split())} | {_why(c)} |"
        )
    return lines


def doc_block(rob: Mapping[str, Any], command: str) -> list[str]:
    """The generated block of docs/results.md: both tables and, for every paper claim that
    is not robust, what its failures share (:mod:`.robustness_interactions`)."""
    n, unf = rob["n"], rob.get("unfiltered", 0)
    lines = [
        BEGIN,
        "",
        f"Generated from `{command}` (seed {rob['seed']}, {n} perturbed set-ups per factor, "
        f"{unf} unfiltered set-ups per experiment, {rob['workers']} workers, "
        f"{rob['seconds']:.0f} s) by `python -m redservo.reproduction.claims_table "
        "out/report.json --doc docs/results.md`. Factors swept: "
        + ", ".join(f for f in rob.get("factors", []) if f != UNFILTERED)
        + (
            "; the image factors (noise, blur, focal length) were not swept: *all* perturbs "
            "the others together, with the ideal sensor"
            if not rob.get("pixel_noise", True)
            else ""
        )
        + ".",
        "",
        "**Paper claims**",
        "",
        *_table(rob, PAPER),
        "",
        "**Implementation and set-up checks**",
        "",
        *_table(rob, "implementation check"),
        "",
        "**What the failures share** (all-factors set-ups, found by the sweep):",
        "",
    ]
    weak = [c for c in rob["checks"] if c["kind"] == PAPER and _category(c) != "robust"]
    for c in weak:
        text = interaction_text(_setups(rob, c["experiment"]), c["name"])
        if text:
            lines.append(f"- `{c['experiment']}` {' '.join(str(c['claim']).split())}: {text}")
    return [*lines, "", END]


def load_robustness(path: Path) -> dict[str, Any]:
    """The ``robustness`` part of a ``report.json`` (or of a trimmed file).

    Raises:
        ConfigurationError: the file is missing, not JSON, or has no robustness sweep.
    """
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise ConfigurationError(f"{path}: cannot read a report.json: {exc}") from exc
    rob = data.get("robustness") if isinstance(data, dict) else None
    if not isinstance(rob, dict) or "checks" not in rob:
        raise ConfigurationError(
            f"{path}: key 'robustness' missing: run `redservo reproduce --robustness N`"
        )
    return data


def trim(report: Mapping[str, Any]) -> dict[str, Any]:
    """What the tables need of a ``report.json``: the command, the sweep's checks and its
    all-factors set-ups (what the failures share is computed from those)."""
    rob = dict(report["robustness"])
    rob["setups"] = [s for s in rob["setups"] if s["factor"] == "all"]
    return {"command": report.get("command", ""), "robustness": rob}


def merge_unfiltered(report: Mapping[str, Any], other: Mapping[str, Any]) -> dict[str, Any]:
    """``report`` with the unfiltered column (tallies and set-ups) of another run's report
    (``redservo reproduce --unfiltered N``) on the same experiments.

    Raises:
        ConfigurationError: ``other`` has no unfiltered set-ups.
    """
    rob, theirs = dict(report["robustness"]), other["robustness"]
    if not theirs.get("unfiltered"):
        raise ConfigurationError("the second report has no unfiltered set-ups (--unfiltered N)")
    cols = {
        (c["experiment"], c["name"]): c["by_factor"][UNFILTERED]
        for c in theirs["checks"]
        if UNFILTERED in c["by_factor"]
    }
    rob["checks"] = [
        {**c, "by_factor": {**c["by_factor"], UNFILTERED: cols[(c["experiment"], c["name"])]}}
        if (c["experiment"], c["name"]) in cols
        else c
        for c in rob["checks"]
    ]
    rob["setups"] = [*rob["setups"], *(s for s in theirs["setups"] if s["factor"] == UNFILTERED)]
    rob["unfiltered"] = theirs["unfiltered"]
    command = f"{report.get('command', '')}` and `{other.get('command', '')}"
    return {**report, "robustness": rob, "command": command}


def replace_block(text: str, block: Sequence[str], where: str = "document") -> str:
    """``text`` with its generated block replaced by ``block``.

    Raises:
        ConfigurationError: the markers are missing or out of order.
    """
    i, j = text.find(BEGIN), text.find(END)
    if i < 0 or j < i:
        raise ConfigurationError(f"{where}: no '{BEGIN}' ... '{END}' block to replace")
    return text[:i] + "\n".join(block) + text[j + len(END) :]


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m redservo.reproduction.claims_table REPORT [--doc FILE] [--trim FILE]``."""
    ap = argparse.ArgumentParser(prog="python -m redservo.reproduction.claims_table")
    ap.add_argument("report", type=Path, help="report.json of `redservo reproduce --robustness`")
    ap.add_argument("--doc", type=Path, help="replace the generated block of this markdown file")
    ap.add_argument("--trim", type=Path, help="write the part of the report the tables need")
    ap.add_argument(
        "--unfiltered", type=Path, help="report.json of `redservo reproduce --unfiltered N`"
    )
    args = ap.parse_args(argv)
    try:
        report = load_robustness(args.report)
        if args.unfiltered is not None:
            report = merge_unfiltered(report, load_robustness(args.unfiltered))
        block = doc_block(report["robustness"], report.get("command") or "redservo reproduce")
        if args.doc is not None:
            args.doc.write_text(replace_block(args.doc.read_text(), block, str(args.doc)))
        else:
            print("\n".join(block))
        if args.trim is not None:
            text = json.dumps(trim(report), separators=(",", ":"), ensure_ascii=False)
            args.trim.write_text(text + "\n")
    except (ConfigurationError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
