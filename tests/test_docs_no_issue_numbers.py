"""The documentation and the shipped scenarios say what they mean instead of citing internal
issue numbers ("issue 19", "#23", "Issue-10 targets"): readers of the site and of a shared
run's scenario.toml cannot look those up. References to other projects' trackers (ViSP's pull
requests) name the project on the same line."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INTERNAL = re.compile(r"\bissues?\b[\s-]*(?:#?\d+|:)|(?<![\w/&])#\d+\b", re.IGNORECASE)
EXTERNAL = re.compile(r"visp|pull request|github\.com", re.IGNORECASE)


def _offending(paths: list[Path]) -> list[str]:
    found = []
    for path in paths:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if INTERNAL.search(line) and not EXTERNAL.search(line):
                found.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    return found


def test_docs_cite_no_internal_issue_numbers() -> None:
    assert _offending(sorted((ROOT / "docs").rglob("*.md"))) == []


def test_shipped_scenarios_cite_no_internal_issue_numbers() -> None:
    scenarios = sorted((ROOT / "src" / "redservo" / "scenarios").glob("*.toml"))
    assert len(scenarios) >= 19
    assert _offending(scenarios) == []


def test_the_pattern_catches_what_it_must() -> None:
    bad = ["## predictive (issue 20)", "**Issue-10 targets**", "see #23", 'paper = "x (issue: y)"']
    good = ["(lagadic/visp issue #1946)", "the [section](#s10.3)", "colour &#8212;", "an issue"]
    assert all(INTERNAL.search(t) and not EXTERNAL.search(t) for t in bad)
    assert not any(INTERNAL.search(t) and not EXTERNAL.search(t) for t in good)
