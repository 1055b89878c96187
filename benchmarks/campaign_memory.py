"""Peak memory of a campaign against its number of samples N (client and worker processes).

Runs ``redservo campaign CAMPAIGN --methods M --samples N --seed 0 --no-plot --workers W
--out DIR -q`` in a child process for each N and, while it runs, reads every ~0.1 s the
peak resident set size (``VmHWM`` of ``/proc/PID/status``, Linux) of the client and of each
of its descendants (the local pool's worker processes). ``VmHWM`` only grows, so the last
reading of a process is its peak up to that instant (a peak reached in the last ~0.1 s
before a process exits can be missed; the client's end-of-run work is seen because the
workers have exited by then and the client keeps running). Prints one line per N: wall
time, rows, the client's peak, the largest worker peak and the sum of the worker peaks (MB
= 10⁶ bytes). docs/scaling.md, "Memory", has the numbers.

Usage::

    python benchmarks/campaign_memory.py --samples 1000,100000 --methods classical
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _hwm_kb(pid: int) -> int | None:
    """``VmHWM`` of a process in KiB (the file's "kB"), or None when it is gone."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    except (OSError, ValueError):
        return None
    return None


def _children(pid: int) -> list[int]:
    """The descendants of ``pid`` (from ``/proc/PID/task/*/children``)."""
    out: list[int] = []
    stack = [pid]
    while stack:
        p = stack.pop()
        for task in Path(f"/proc/{p}/task").glob("*"):
            try:
                kids = [int(k) for k in (task / "children").read_text().split()]
            except (OSError, ValueError):
                continue
            out.extend(kids)
            stack.extend(kids)
    return out


def measure(
    campaign: str, methods: str, n: int, workers: int, out: Path, period: float = 0.1
) -> dict[str, float]:
    """Run one campaign in a child process and return its peaks (kB) and wall time (s)."""
    exe = Path(sys.executable).with_name("redservo")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "redservo"]
    cmd += [
        "campaign", campaign, "--methods", methods, "--samples", str(n), "--seed", "0",
        "--no-plot", "--workers", str(workers), "--out", str(out), "-q",
    ]  # fmt: skip
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL)
    peaks: dict[int, int] = {}
    while proc.poll() is None:
        for pid in [proc.pid, *_children(proc.pid)]:
            kb = _hwm_kb(pid)
            if kb is not None:
                peaks[pid] = max(peaks.get(pid, 0), kb)
        time.sleep(period)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"campaign with N = {n} failed (exit {proc.returncode}): {cmd}")
    rows = sum(1 for _ in (out / "samples.csv").open()) - 1
    kids = [v for p, v in peaks.items() if p != proc.pid]
    return {
        "wall": wall,
        "rows": rows,
        "client": peaks.get(proc.pid, 0),
        "worker_max": max(kids, default=0),
        "worker_sum": sum(kids),
        "workers": len(kids),
    }


def _mb(kib: float) -> str:
    return f"{kib * 1024 / 1e6:.0f}"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaign", default="cm01-gaze")
    ap.add_argument("--methods", default="classical")
    ap.add_argument("--samples", default="300,1000,3000", help="comma-separated N")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--keep", help="keep the output directories under this directory")
    args = ap.parse_args(argv)
    if not Path("/proc/self/status").exists():
        raise SystemExit("campaign_memory.py reads /proc/PID/status (Linux only)")
    ns = [int(s) for s in args.samples.split(",")]
    base = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="campaign-memory-"))
    print(
        f"campaign {args.campaign}, methods {args.methods}, --workers {args.workers}; "
        "peak RSS (VmHWM) in MB",
        flush=True,
    )
    print("| N | rows | wall (s) | client | largest worker | workers (sum) |")
    print("|---:|---:|---:|---:|---:|---:|", flush=True)
    try:
        for n in ns:
            print(f"running N = {n} ...", file=sys.stderr, flush=True)
            out = base / f"n{n}"
            shutil.rmtree(out, ignore_errors=True)
            r = measure(args.campaign, args.methods, n, args.workers, out)
            print(
                f"| {n} | {r['rows']} | {r['wall']:.0f} | {_mb(r['client'])} | "
                f"{_mb(r['worker_max'])} | {_mb(r['worker_sum'])} "
                f"({r['workers']} processes) |",
                flush=True,
            )
    finally:
        if not args.keep:
            shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
