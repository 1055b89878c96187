"""Compare joint-limit avoidance methods on one scenario (the Python side of
``redservo compare``): the same task, a table of outcomes with their success verdicts, speeds and margins.

    python examples/compare_methods.py [--out DIR] [--quick]
"""

from __future__ import annotations

import argparse

import redservo
from redservo.records import outcome_text

METHODS = ["classical", "gpm-auto", "iterative-smooth", "directional"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="save one run per method and compare.md here")
    parser.add_argument("--quick", action="store_true", help="30 iterations per method (tests)")
    args = parser.parse_args(argv)

    options = {"max_iterations": 30} if args.quick else {}
    # CM01 §V-A: the Afma6 starts near the limits of three axes; the classical law has no
    # avoidance (the default safety shield still keeps it off the limits).
    results = redservo.compare("cm01-gaze", METHODS, out=args.out, **options)
    print(
        f"{'method':18s} {'iters':>5s} {'min margin':>10s} {'peak |q̇|/max':>13s}  outcome and verdict"
    )
    for method, r in results.items():
        s = r.summary
        ratio = "-" if s.peak_velocity_ratio is None else f"{s.peak_velocity_ratio:.2f}"
        # "converged" alone is not "safe": the verdict says whether the shield had to act.
        print(
            f"{method:18s} {s.iterations:5d} {s.min_margin:10.3f} {ratio:>13s}  {outcome_text(s)}"
        )
    if args.out:
        print(f"overlaid figures: redservo plot {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
