"""``redservo campaign --check-reach``: the independent reachability check of a campaign.

After the campaign, every sample whose ``reachable`` column is known (``True``/``False``,
decided by :mod:`redservo.campaign.reach`, the inverse kinematics the ``predictive`` law
shares) is judged again by :func:`redservo.campaign.reach_check.reachable_independent`
(bounded least squares from Sobol starts, nothing shared but the forward kinematics). The
samples the two judge differently are listed in ``campaign.md`` (a section "Reachability
check") and ``campaign.json`` (key ``"reach_check"``). It runs in this process, about one
CPU second per sample on the shipped campaigns (docs/results.md), so it is an option, not
the default. A later call without ``--check-reach`` rewrites both files without it.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

__all__ = ["ReachCheck", "check_campaign", "reach_markdown", "write_reach_check"]


class ReachCheck(NamedTuple):
    """The two reachability verdicts of a campaign's samples."""

    checked: int
    """Samples both methods judged (a known ``reachable`` column)."""
    reachable: int
    """Of those, reachable by :mod:`redservo.campaign.reach` (the campaign's column)."""
    reachable_independent: int
    """Of those, reachable by :func:`~redservo.campaign.reach_check.reachable_independent`."""
    disagreements: list[tuple[int, bool, bool]]
    """``(sample, campaign's column, independent check)`` where they differ."""
    cpu_s: float
    """CPU time of the independent check, all samples (s)."""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``campaign.json``'s ``"reach_check"``)."""
        return {
            "checked": self.checked,
            "reachable": self.reachable,
            "reachable_independent": self.reachable_independent,
            "agree": self.checked - len(self.disagreements),
            "disagreements": [
                {"sample": i, "reachable": a, "reachable_independent": b}
                for i, a, b in self.disagreements
            ],
            "cpu_s_per_sample": self.cpu_s / self.checked if self.checked else None,
        }


def _column(rows: Sequence[dict[str, Any]]) -> dict[int, bool]:
    """Sample -> its ``reachable`` column, for the samples where it is known."""
    known: dict[int, bool] = {}
    for row in rows:
        value = str(row.get("reachable") or "")
        if value:
            known.setdefault(int(row["sample"]), value == "True")
    return known


def check_campaign(defn: Any, seed: int, rows: Sequence[dict[str, Any]]) -> ReachCheck:
    """Judge again, independently, every sample of ``rows`` (``samples.csv`` rows of the
    campaign ``defn`` drawn with ``seed``) whose ``reachable`` column is known."""
    from redservo.campaign.reach_check import disagreements, reachable_independent
    from redservo.campaign.sampling import draw_sample
    from redservo.experiment.build import build

    known = _column(rows)
    ids = sorted(known)
    second: list[bool | None] = []
    start = time.process_time()
    for i in ids:
        second.append(reachable_independent(build(draw_sample(defn, seed, i).scenario)))
    cpu = time.process_time() - start
    first = [known[i] for i in ids]
    return ReachCheck(
        len(ids),
        sum(first),
        sum(bool(b) for b in second),
        disagreements(ids, first, second),
        cpu,
    )


def reach_markdown(check: ReachCheck) -> str:
    """The ``campaign.md`` section of the check."""
    n = check.checked
    lines = [
        "## Reachability check",
        "",
        f"Samples judged: {n}; reachable by the campaign's inverse kinematics "
        f"(redservo.campaign.reach, shared with the predictive law): {check.reachable}; by the "
        f"independent check (bounded least squares from Sobol starts): "
        f"{check.reachable_independent}; agree on {n - len(check.disagreements)}/{n}.",
    ]
    if check.disagreements:
        lines += ["", "| sample | campaign's reachable | independent check |", "|---|---|---|"]
        lines += [f"| {i} | {a} | {b} |" for i, a, b in check.disagreements]
    else:
        lines += ["", "No disagreement."]
    return "\n".join(lines) + "\n"


def write_reach_check(out: Path, check: ReachCheck) -> None:
    """Append the section to ``out/campaign.md`` and the key ``"reach_check"`` to
    ``out/campaign.json`` (both written by the campaign just before)."""
    md = Path(out) / "campaign.md"
    md.write_text(md.read_text().rstrip("\n") + "\n\n" + reach_markdown(check))
    js = Path(out) / "campaign.json"
    meta = json.loads(js.read_text())
    meta["reach_check"] = check.to_dict()
    js.write_text(json.dumps(meta, indent=2) + "\n")
