"""Benchmark: the control step of every method, checked against the issue-10 targets.

    .venv/bin/python benchmarks/bench_control_step.py [--repeat N] [--rounds R] [--out bench.json]
    .venv/bin/python benchmarks/bench_control_step.py --from bench.json   # re-check saved numbers
    .venv/bin/python benchmarks/bench_control_step.py --visp benchmarks/visp/visp_step

Runs ``redservo bench`` (every case, the scaling with n, the reference path), prints its
tables, writes the JSON, then compares the medians with the targets of issue 10 on the
compiled path. The machine is shared and its load varies: run it more than once and
read the load average printed in the first line; the figures are medians over
interleaved rounds. With ``--visp PATH`` (the optional ViSP harness, ``sh
benchmarks/visp/build.sh``) ViSP's step on the same 4-point case is timed in the same run,
``--rounds`` batches of ``--repeat`` steps before and as many after ``redservo bench``, on
the wall clock as ``redservo bench`` times redservo's, and the ratios use its median (else
:data:`VISP_US`). On a loaded machine prefer ``benchmarks/bench_object_path.py --visp PATH
--clock cpu``, which interleaves ViSP with the items in every round on the CPU clock.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

TARGETS: list[tuple[str, str, str, str, float]] = [
    *(
        ("4-point step", "afma6-4points", m, "compiled", 15.0)
        for m in ("classical", "iterative-smooth", "directional", "large-projection")
    ),
    *(("bounds active", "panda-6d-bounds", m, "compiled", 30.0) for m in ("sns", "qp")),
    ("moment features", "afma6-moments", "-", "compiled", 20.0),
]
"""(what, case, method, path, limit in µs): issue 10, item 3."""
IMPORT_TARGET_S = 0.3
VISP_US = 7.3
"""ViSP 3.5's ``vpServo`` step on the 4-point Afma6 case (µs), as issue 29 measured it on a
quiet machine: the fallback when the harness (``--visp``) is not given."""
VISP_RATIO = {"qp": 1.6}
"""Issue 29's targets for the compiled 4-point step as ratios to :data:`VISP_US` (1.3 for
the methods not listed)."""


def visp_check(data: dict[str, Any], visp_us: float = VISP_US) -> list[str]:
    """One line per method of the compiled ``afma6-4points`` step: its ratio to ViSP's step
    and issue 29's target (≤ 1.3x, ``qp`` ≤ 1.6x)."""
    lines = []
    for r in data["rows"]:
        if r["case"] != "afma6-4points" or r["path"] != "compiled":
            continue
        ratio, target = r["median_us"] / visp_us, VISP_RATIO.get(r["method"], 1.3)
        verdict = "met" if ratio <= target else "missed"
        lines.append(
            f"afma6-4points, {r['method']}: {r['median_us']:.1f} µs = {ratio:.2f}x ViSP "
            f"({visp_us:.3g} µs; target ≤ {target:g}x): {verdict}"
        )
    return lines


def visp_rounds(path: Path, rounds: int, batch: int) -> list[float]:
    """ViSP's step (µs, wall clock, as ``redservo bench`` times redservo's) in ``rounds``
    batches of ``batch`` steps, by the harness at ``path`` (:mod:`visp.harness` of this
    folder).

    Raises:
        SystemExit: (code 2, one line on stderr) the harness is missing or fails.
    """
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_object_path import the_case
    from visp.harness import HarnessError, VispStep

    try:
        step = VispStep(path, the_case())
        try:
            return [step.per_call_us(batch, cpu=False) for _ in range(rounds)]
        finally:
            step.close()
    except (HarnessError, OSError) as err:
        print(f"bench_control_step.py: {err}", file=sys.stderr)
        raise SystemExit(2) from None


def check(data: dict[str, Any]) -> list[str]:
    """One line per target: the median, the limit, met or missed and by how much."""
    rows = {(r["case"], r["method"], r["path"]): r for r in data["rows"]}
    lines = []
    for what, case, method, path, limit in TARGETS:
        r = rows.get((case, method, path))
        if r is None:
            lines.append(f"{what}, {case}, {method}: not measured")
            continue
        med = r["median_us"]
        verdict = "met" if med <= limit else f"MISSED by {med - limit:.1f} µs ({med / limit:.2f}x)"
        lines.append(f"{what}, {case}, {method}: {med:.1f} µs (target ≤ {limit:g} µs): {verdict}")
    imp = data.get("first_call_s", {}).get("import redservo")
    if imp is not None:
        verdict = "met" if imp <= IMPORT_TARGET_S else f"MISSED by {imp - IMPORT_TARGET_S:.2f} s"
        lines.append(f"import redservo: {imp:.3f} s (target ≤ {IMPORT_TARGET_S} s): {verdict}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=10)
    parser.add_argument("--out", type=Path, default=Path("bench.json"))
    parser.add_argument("--from", dest="saved", type=Path, help="check a saved JSON instead")
    parser.add_argument(
        "--visp", type=Path, metavar="PATH", help="ViSP's step harness, timed in the same run"
    )
    args = parser.parse_args()
    visp: list[float] = []
    if args.saved is not None:
        data = json.loads(args.saved.read_text())
    else:
        from redservo.bench.steps import run_bench
        from redservo.cli.bench import _progress

        if args.visp is not None:
            visp += visp_rounds(args.visp, args.rounds, args.repeat)
        result = run_bench(repeat=args.repeat, rounds=args.rounds, progress=_progress(True))
        if args.visp is not None:
            visp += visp_rounds(args.visp, args.rounds, args.repeat)
        print(result.markdown)
        data = result.to_json()
        if visp:
            data["visp"] = {"median_us": float(np.median(visp)), "rounds_us": visp}
        args.out.write_text(json.dumps(data, indent=2))
        print(f"\nwrote {args.out}", file=sys.stderr)
    print("\nIssue-10 targets (medians, compiled path):\n")
    for line in check(data):
        print(f"- {line}")
    visp_us = data.get("visp", {}).get("median_us", VISP_US)
    source = "measured in this run" if "visp" in data else "issue 29's figure"
    print(f"\nIssue-29 targets (the compiled 4-point step against ViSP's, {source}):\n")
    for line in visp_check(data, visp_us):
        print(f"- {line}")


if __name__ == "__main__":
    main()
