"""Benchmark: do the two reachability methods agree on a campaign's samples, and at what cost?

    .venv/bin/python benchmarks/reach_agreement.py [--campaign panda-near-limits] \
        [--samples 200] [--seed 0]

draws the campaign's samples exactly as ``redservo campaign`` does
(:func:`redservo.campaign.sampling.draw_sample`), builds each sample's experiment and judges
its goal with both :func:`redservo.campaign.reach.reachable` (the campaign's ``reachable``
column: the projected damped least squares of :mod:`redservo.robots.ik`, shared with the
``predictive`` law) and :func:`redservo.campaign.reach_check.reachable_independent`
(bounded ``least_squares`` from Sobol starts). It prints the counts, the agreement, the
disagreements (sample, first, second) and the CPU seconds per sample of each method
(``time.process_time``, inflated on a shared machine). docs/results.md gives the numbers.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from typing import NamedTuple

__all__ = ["Agreement", "agreement", "main"]


class Agreement(NamedTuple):
    samples: list[int]
    first: list[bool | None]
    """:func:`redservo.campaign.reach.reachable` per sample."""
    second: list[bool | None]
    """:func:`redservo.campaign.reach_check.reachable_independent` per sample."""
    cpu_first: float
    """CPU seconds, all samples (s)."""
    cpu_second: float


def agreement(campaign: str, samples: int, seed: int, *, progress: bool = False) -> Agreement:
    """Both verdicts on the first ``samples`` samples of ``campaign`` drawn with ``seed``
    (``progress``: print each sample's verdicts and CPU seconds as it goes)."""
    from redservo.campaign.definition import load_campaign
    from redservo.campaign.reach import reachable
    from redservo.campaign.reach_check import reachable_independent
    from redservo.campaign.sampling import draw_sample
    from redservo.experiment.build import build

    defn = load_campaign(campaign)
    out = Agreement(list(range(samples)), [], [], 0.0, 0.0)
    c1 = c2 = 0.0
    for i in out.samples:
        exp = build(draw_sample(defn, seed, i).scenario)
        t0 = time.process_time()
        out.first.append(reachable(exp))
        t1 = time.process_time()
        out.second.append(reachable_independent(exp))
        t2 = time.process_time()
        c1, c2 = c1 + t1 - t0, c2 + t2 - t1
        if progress:
            print(i, out.first[-1], out.second[-1], f"{t1 - t0:.2f} {t2 - t1:.2f}", flush=True)
    return out._replace(cpu_first=c1, cpu_second=c2)


def main(argv: Sequence[str] | None = None) -> None:
    from redservo.campaign.reach_check import disagreements

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--campaign", default="panda-near-limits")
    p.add_argument("--samples", type=int, default=200)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    r = agreement(a.campaign, a.samples, a.seed, progress=True)
    n = len(r.samples)
    both = sum(x is not None and y is not None and x == y for x, y in zip(r.first, r.second))
    diff = disagreements(r.samples, r.first, r.second)
    print(f"campaign {a.campaign}, {n} samples, seed {a.seed}")
    print(f"reach.reachable (shared IK): {sum(x is True for x in r.first)} reachable")
    print(f"reach_check (independent):   {sum(x is True for x in r.second)} reachable")
    print(f"agree on {both}/{n}; disagreements (sample, shared IK, independent): {diff}")
    print(
        f"CPU per sample: shared IK {1e3 * r.cpu_first / n:.0f} ms, "
        f"independent {1e3 * r.cpu_second / n:.0f} ms"
    )


if __name__ == "__main__":
    main()
