"""The ``redservo bench`` subcommand: arguments, progress on stderr, markdown and JSON output."""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from redservo.cli.common import method_list

__all__ = ["add_bench_arguments", "main_bench"]


def add_bench_arguments(b: argparse.ArgumentParser, int_in: Callable[..., Any]) -> None:
    """Add the options of ``redservo bench`` to its subparser."""
    b.add_argument(
        "--repeat",
        type=int_in(1, 1_000_000),
        default=1000,
        help="timed calls per item in total, spread over the rounds (default 1000)",
    )
    b.add_argument(
        "--rounds",
        type=int_in(1, 10_000),
        default=10,
        help="interleaved rounds; medians are taken over them (default 10)",
    )
    b.add_argument("--methods", type=method_list, help="comma-separated methods (default: all)")
    b.add_argument(
        "--cases",
        help="comma-separated main cases (default: afma6-4points, afma6-gaze, afma6-moments, "
        "panda-6d-free, panda-6d-bounds)",
    )
    b.add_argument(
        "--scaling",
        default="6,10,20,30,50",
        help="joint counts of the scaling cases, comma-separated, or 'none' (default 6,...,50)",
    )
    b.add_argument(
        "--no-reference",
        action="store_true",
        help="skip the reference timings (the kernels run as plain Python, numba disabled)",
    )
    b.add_argument(
        "--out",
        "--json",
        dest="json",
        metavar="PATH",
        help="also write the numbers as JSON to PATH (--json is the same option)",
    )


def _split(text: str | None) -> list[str] | None:
    if text is None:
        return None
    return [t.strip() for t in text.split(",") if t.strip()]


def _progress(enabled: bool) -> Callable[[int, int, str], None] | None:
    """A progress line on stderr: rewritten in place on a terminal, every 10 % otherwise."""
    if not enabled:
        return None
    tty = sys.stderr.isatty()
    state = {"shown": -1, "t0": time.monotonic()}

    def show(done: int, total: int, label: str) -> None:
        pct = 100 * done // total
        if tty:
            sys.stderr.write(f"\rbench {done}/{total} ({pct}%) {label:<60.60}")
            if done == total:
                sys.stderr.write("\n")
        elif pct // 10 > state["shown"] or done == total:
            state["shown"] = pct // 10
            elapsed = time.monotonic() - state["t0"]
            sys.stderr.write(f"bench {done}/{total} ({pct}%, {elapsed:.0f} s) {label}\n")
        sys.stderr.flush()

    return show


def main_bench(args: argparse.Namespace) -> int:
    """Run the benchmark with the parsed ``args``; print markdown, write JSON if asked."""
    from redservo.bench.steps import run_bench
    from redservo.errors import ConfigurationError
    from redservo.redundancy import law_class

    methods: list[str] | None = args.methods
    for m in methods or ():
        law_class(m)  # unknown names fail before anything runs
    if args.scaling.strip().lower() in ("", "none"):
        scaling: tuple[int, ...] = ()
    else:
        try:
            scaling = tuple(int(v) for v in _split(args.scaling) or ())
        except ValueError:
            raise ConfigurationError(
                f"--scaling: give joint counts like 6,10,20 or 'none', got {args.scaling!r}",
                argument="scaling",
            ) from None
    if not args.quiet:
        sys.stderr.write("bench: compiling or loading the kernels, then timing...\n")
    result = run_bench(
        repeat=args.repeat,
        rounds=args.rounds,
        methods=methods,
        cases=_split(args.cases),
        scaling=scaling,
        reference=not args.no_reference,
        progress=_progress(not args.quiet),
    )
    print(result.markdown)
    if args.json:
        Path(args.json).write_text(json.dumps(result.to_json(), indent=2))
        print(f"wrote {args.json}")
    return 0
