"""`make demo`: reproduce both papers and run a small Monte Carlo comparison.

Writes, under ``--out`` (default ``out/``):

* ``report.md``, ``report.json`` and every figure of the reproduction of
  Chaumette & Marchand 2001 and Mansard & Chaumette 2005 (``redservo reproduce``);
* ``campaign/``: a small campaign (seconds, not minutes) comparing the methods on
  random starts near the joint limits (``redservo campaign afma6-gaze-demo``).
"""

from __future__ import annotations

import argparse
import sys

from redservo.cli import main


def run() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="out", help="output directory (default out/)")
    args = parser.parse_args()
    code = main(["reproduce", "--out", args.out])
    if code:
        return code
    return main(
        [
            "campaign",
            "afma6-gaze-demo",
            "--samples",
            "12",
            "--seed",
            "0",
            "--out",
            f"{args.out}/campaign",
        ]
    )


if __name__ == "__main__":
    sys.exit(run())
