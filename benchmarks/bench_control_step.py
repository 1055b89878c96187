"""Benchmark: time per control step for every method (issue 5 speed target).

    .venv/bin/python benchmarks/bench_control_step.py [--repeat N] [--out bench.json]

Prints the markdown table of ``redservo bench`` and writes the raw numbers as
JSON. Run it on an otherwise idle machine: the SVD-unit column is the figure to
compare across machines. Target: the full step of ``iterative-smooth`` on the
Afma6 gazing task ≤ 60 µs median and ≤ 7 SVD units.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict
from pathlib import Path

from redservo.bench import run_bench


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=3000)
    parser.add_argument("--out", type=Path, default=Path("bench.json"))
    args = parser.parse_args()
    result = run_bench(repeat=args.repeat)
    print(result.markdown)
    args.out.write_text(
        json.dumps(
            {
                "svd_us": result.svd_us,
                "cores": result.cores,
                "rows": [asdict(r) | {"full_units": r.full_units} for r in result.rows],
                "throughput_steps_per_s": result.throughput,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
