"""Why the reactive laws stop near 70 % of the reachable samples: is the goal reachable *locally*?

    .venv/bin/python benchmarks/reactive_reach.py --campaign panda-near-limits \
        --rows runs/panda-near-limits/samples.csv [--seed 0] [--long LONG/samples.csv] \
        [--local local.csv]

A campaign sample is *reachable* (column ``reachable``) when the search of
:mod:`redservo.campaign.reach` finds a goal configuration within the success margin from any
of its seeds: the sample's start, the nominal start, the middle of the ranges, four starts
near the sample's start and 60 random ones. A reactive law (every method but ``predictive``)
only descends the task error from the start, so this script asks the same search from the
sample's start alone (:func:`start_reachable`: the projected damped least squares of
:mod:`redservo.robots.ik` on the desired camera pose, then on the task error, within the
margin). Where that descent stalls at the joint bounds, the goal lies in another region of
the joint space (another inverse-kinematics branch): reaching it needs a motion that first
*increases* the error, which no reactive law makes.

It prints, per method, the successes among the reachable samples split into the *locally*
reachable ones (start-seeded search succeeds) and the others, as a markdown table
(:func:`split_lines`). With ``--long`` (the same campaign rerun with a larger iteration cap,
``[overrides] simulation = { max_iterations = ... }``) it also counts, per method, the
failures of ``--rows`` that converge given the longer cap (a slow decay) and those that stay
where they were (a stall). ``--local`` caches the per-sample verdicts in a CSV file
(``sample,local``), written on the first run and read on the next. docs/results.md gives the
numbers.
"""

from __future__ import annotations

import argparse
import csv
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

__all__ = ["Split", "main", "slow_or_stalled", "split", "split_lines", "start_reachable"]


class Split(NamedTuple):
    """Successes of one method: among the reachable samples, and among those the locally
    reachable (``local``) and the others (``other``), each ``(successes, samples)``."""

    reachable: tuple[int, int]
    local: tuple[int, int]
    other: tuple[int, int]


def start_reachable(exp: Any) -> bool:
    """Whether the reach search's own descent from the sample's start (and only from it)
    finds the goal: the desired camera pose, else a task error below half the tolerance,
    with every joint at least the success margin (fraction of its range) inside its limits."""
    import numpy as np

    from redservo.campaign.reach import desired_camera_pose, feature_solution
    from redservo.robots.ik import solve_ik

    lim = exp.limits
    rng = lim.q_max - lim.q_min
    lo = lim.q_min + exp.options.min_margin * rng
    hi = lim.q_max - exp.options.min_margin * rng
    q0 = np.asarray(exp.q0, dtype=float)
    target = desired_camera_pose(exp)
    if target is not None and solve_ik(exp.robot, target, q0, lo, hi) is not None:
        return True
    return feature_solution(exp, q0, lo, hi, 0.5 * exp.options.tolerance) is not None


def _true(value: Any) -> bool:
    return str(value).strip().lower() == "true"


def split(rows: Sequence[Mapping[str, Any]], local: Mapping[int, bool]) -> dict[str, Split]:
    """Per method, the successes among the reachable samples of ``rows`` (``samples.csv``
    rows: ``sample``, ``method``, ``reachable``, ``success``) split by ``local`` (sample ->
    start-seeded verdict; a reachable sample missing from it is an error)."""
    counts: dict[str, list[int]] = {}
    for row in rows:
        if not _true(row["reachable"]):
            continue
        sample = int(row["sample"])
        if sample not in local:
            raise KeyError(f"sample {sample} has no start-seeded verdict")
        c = counts.setdefault(str(row["method"]), [0] * 6)
        ok = int(_true(row["success"]))
        k = 2 if local[sample] else 4
        c[0], c[1], c[k], c[k + 1] = c[0] + ok, c[1] + 1, c[k] + ok, c[k + 1] + 1
    return {m: Split((c[0], c[1]), (c[2], c[3]), (c[4], c[5])) for m, c in sorted(counts.items())}


def _pct(pair: tuple[int, int]) -> str:
    ok, n = pair
    return f"{ok}/{n} = {100.0 * ok / n:.1f} %" if n else "—"


def split_lines(result: Mapping[str, Split]) -> list[str]:
    """:func:`split` as a markdown table."""
    lines = [
        "| method | success among reachable | among reachable from the start | among the others |",
        "|---|---:|---:|---:|",
    ]
    for method, s in result.items():
        lines.append(f"| {method} | {_pct(s.reachable)} | {_pct(s.local)} | {_pct(s.other)} |")
    return lines


def slow_or_stalled(
    rows: Sequence[Mapping[str, Any]], long_rows: Sequence[Mapping[str, Any]]
) -> dict[str, tuple[int, int]]:
    """Per method, ``(slow, stalled)``: the reachable runs of ``rows`` that ended at the
    iteration cap and converge in ``long_rows`` (the same samples with a larger cap), and
    those that do not."""
    longer = {(int(r["sample"]), str(r["method"])): r["outcome"] == "converged" for r in long_rows}
    out: dict[str, tuple[int, int]] = {}
    for row in rows:
        key = (int(row["sample"]), str(row["method"]))
        if row["outcome"] != "max_iterations" or not _true(row["reachable"]) or key not in longer:
            continue
        slow, stalled = out.get(key[1], (0, 0))
        out[key[1]] = (slow + 1, stalled) if longer[key] else (slow, stalled + 1)
    return dict(sorted(out.items()))


def _read(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def _local_verdicts(
    campaign: str, seed: int, samples: Sequence[int], cache: Path | None
) -> dict[int, bool]:
    """The start-seeded verdicts of ``samples`` (read from ``cache`` when it has them all)."""
    if cache is not None and cache.exists():
        got = {int(r["sample"]): _true(r["local"]) for r in _read(cache)}
        if all(s in got for s in samples):
            return got
    from redservo.campaign.definition import load_campaign
    from redservo.campaign.sampling import draw_built
    from redservo.experiment.build import build

    defn = load_campaign(campaign)
    out: dict[int, bool] = {}
    for i in samples:
        sample, exp = draw_built(defn, seed, i)
        out[i] = start_reachable(exp if exp is not None else build(sample.scenario))
    if cache is not None:
        with cache.open("w", newline="") as fh:
            fh.write("sample,local\n" + "".join(f"{i},{v}\n" for i, v in sorted(out.items())))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--campaign", required=True, help="a shipped campaign name or .toml file")
    ap.add_argument("--rows", type=Path, required=True, help="the campaign's samples.csv")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--long", type=Path, help="samples.csv of a rerun with a larger cap")
    ap.add_argument("--local", type=Path, help="CSV cache of the start-seeded verdicts")
    args = ap.parse_args(argv)
    rows = _read(args.rows)
    reach = sorted({int(r["sample"]) for r in rows if _true(r["reachable"])})
    local = _local_verdicts(args.campaign, args.seed, reach, args.local)
    print(f"{len(reach)} reachable samples, {sum(local[i] for i in reach)} locally reachable")
    print("\n".join(split_lines(split(rows, local))))
    if args.long is not None:
        for method, (slow, stalled) in slow_or_stalled(rows, _read(args.long)).items():
            print(f"{method}: runs at the cap on reachable samples: {slow} slow, {stalled} stalled")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
