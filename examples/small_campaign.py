"""A small Monte Carlo campaign (the Python side of ``redservo campaign``): several methods
on the same random start configurations near the joint limits, with success rates and
their 95 % Wilson intervals.

    python examples/small_campaign.py [--samples N] [--workers K] [--out DIR] [--quick]
"""

from __future__ import annotations

import argparse

import redservo


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=20, help="random variations (default 20)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--out", help="store samples.csv, campaign.md and figures here")
    parser.add_argument("--quick", action="store_true", help="2 samples, 2 methods (tests)")
    args = parser.parse_args(argv)

    methods = ["classical", "gpm", "iterative-smooth"]
    result = redservo.campaign(
        "afma6-gaze-demo",
        methods=methods[:2] if args.quick else methods,
        samples=2 if args.quick else args.samples,
        seed=0,  # same seed, same samples, whatever the number of workers
        workers=args.workers,
        out=args.out,
    )
    for method, st in result.stats.items():
        print(
            f"{method:18s} success {st.successes}/{st.runs} "
            f"[{st.ci_low:.2f}, {st.ci_high:.2f}], limit hits {st.limit_hits}, "
            f"median iterations {st.iterations_median:.0f}"
        )
    if args.out:
        print(
            f"table and notes: {args.out}/campaign.md; one sample: redservo replay {args.out} ..."
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
