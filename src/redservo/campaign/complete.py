"""A campaign's completeness, checked rather than assumed (docs/campaigns.md, "Completeness").

Whatever the engine, :func:`redservo.campaign.run_campaign` counts at the end the rows it has
for every ``(sample, method)`` it was asked for. When any is missing (an engine lost a job,
every Dask worker died, a local worker process was killed) it raises
:class:`CampaignIncompleteError`, which names the missing samples and methods: the rows that
were stored are kept, and rerunning the same campaign in the same output directory computes
only the missing runs.
"""

from __future__ import annotations

from collections.abc import Container, Sequence
from pathlib import Path
from typing import Any

from redservo.errors import RedservoError

__all__ = ["CampaignIncompleteError", "describe_missing", "incomplete_message", "missing_runs"]

_LISTED = 12
"""Samples named one by one in a message (the count of the others follows)."""


class CampaignIncompleteError(RedservoError, RuntimeError):
    """A campaign ended without a row for every (sample, method) it was asked for.

    The rows that were computed are stored (with an output directory); rerunning the same
    campaign there computes only the missing runs. On the command line: one line, exit 2.

    Attributes:
        missing: The missing ``(sample, method)`` pairs, sorted (empty when an engine stopped
            before the client counted them).
        result: The :class:`~redservo.campaign.CampaignResult` of the rows present (its
            statistics state the N actually completed per method), or None.
    """

    def __init__(
        self,
        message: str,
        *,
        missing: Sequence[tuple[int, str]] = (),
        result: Any = None,
    ) -> None:
        super().__init__(message)
        self.missing = tuple(missing)
        self.result = result


def missing_runs(
    present: Container[tuple[int, str]], n: int, methods: Sequence[str]
) -> list[tuple[int, str]]:
    """The ``(sample, method)`` pairs of samples ``0..n-1`` and ``methods`` not in ``present``."""
    return [(i, m) for i in range(n) for m in methods if (i, m) not in present]


def describe_missing(missing: Sequence[tuple[int, str]], methods: Sequence[str]) -> str:
    """The missing runs in words: the samples missing every method, then the others with
    their methods (the first :data:`_LISTED` samples named, then a count)."""
    by_sample: dict[int, list[str]] = {}
    for i, m in missing:
        by_sample.setdefault(i, []).append(m)
    whole = [i for i, ms in by_sample.items() if len(ms) == len(methods)]
    parts: list[str] = []
    if whole:
        parts.append(f"{_samples(whole)} (every method)")
    for i, ms in by_sample.items():
        if len(ms) != len(methods):
            parts.append(f"sample {i} ({', '.join(ms)})")
    shown = parts[: _LISTED + 1]
    more = len(parts) - len(shown)
    return "; ".join(shown) + (f"; and {more} more samples" if more else "")


def _samples(ids: list[int]) -> str:
    head = ", ".join(map(str, ids[:_LISTED]))
    more = f" and {len(ids) - _LISTED} more" if len(ids) > _LISTED else ""
    return f"sample{'s' if len(ids) > 1 else ''} {head}{more}"


def incomplete_message(
    name: str,
    missing: Sequence[tuple[int, str]],
    total: int,
    methods: Sequence[str],
    out: Path | None,
    reason: str | None,
) -> str:
    """One line: what is missing, why (when an engine said so), and how to resume."""
    why = f" ({reason})" if reason else ""
    if out is not None:
        present = total - len(missing)
        stored = f"the {present} rows present are stored" if present else "no row is stored yet"
        resume = (
            f"{stored} in {out / 'samples.csv'}; the campaign is resumable: rerun the same "
            "command (same --out and --seed) to compute only the missing runs"
        )
    else:
        resume = (
            "nothing was stored (no output directory): give one (--out, or out=) so that a "
            "rerun resumes"
        )
    return (
        f"campaign {name} is incomplete{why}: {len(missing)} of {total} runs missing: "
        f"{describe_missing(missing, methods)}; {resume}"
    )
