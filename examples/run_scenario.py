"""Load a shipped scenario, change a key, run it and look at the result (the Python side of
``redservo run``).

    python examples/run_scenario.py [SCENARIO] [--out DIR] [--quick]
"""

from __future__ import annotations

import argparse

import numpy as np

import redservo
from redservo.records import outcome_text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default="cm01-gaze", help="name or .toml path")
    parser.add_argument("--out", help="save the run directory here (redservo plot/view it)")
    parser.add_argument("--quick", action="store_true", help="30 iterations only (tests)")
    args = parser.parse_args(argv)

    # Any key of the file can be changed (dotted paths, as --set on the command line).
    sc = redservo.load_scenario(args.scenario, {"control.lam": 0.4})
    print(f"{sc.name}: {sc.spec.description or sc.spec.paper}")
    print(f"  robot {sc.spec.robot.model or sc.spec.robot.urdf}, method {sc.method}")

    options = {"max_iterations": 30} if args.quick else {}
    result = redservo.run(sc, out=args.out, **options)
    s = result.summary
    print(f"  {outcome_text(s)}")  # the outcome and whether it was a success (why not, if not)
    print(f"  {s.iterations} iterations, final |e| = {s.final_error_norm:.2e}")
    print(f"  closest approach to a joint limit: {s.min_margin:.1%} of the range")
    # The log holds one row per iteration: q (N, n), e, camera_twist, flags, ...
    q = result.log.q
    moved = np.abs(q[-1] - q[0])
    print(f"  joint {int(np.argmax(moved))} moved most: {moved.max():.3f} (m or rad)")
    if args.out:
        print(f"  saved to {args.out}: redservo plot {args.out}; redservo.load_run({args.out!r})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
