"""`make demo`: reproduce both papers, run a small Monte Carlo comparison, and animate a run.

On a fresh install it runs the kernels uncompiled (the same numbers: compiling them would
cost more than these short jobs; ``redservo warmup`` compiles them once for campaigns and
long runs, docs/speed.md), on a warmed-up machine compiled. It writes, under ``--out``
(default ``out/``):

* ``report.md``, ``report.json`` and every figure of the reproduction of
  Chaumette & Marchand 2001 and Mansard & Chaumette 2005 (``redservo reproduce``; SVG for
  the report and 300 dpi PNG);
* ``campaign/``: a small campaign (seconds, not minutes) comparing the methods on random
  starts near the joint limits (``redservo campaign afma6-gaze-demo``);
* ``panda-4points/``: one self-describing run of the Franka Panda whose elbow starts near
  its limit (``redservo run panda-4points``), its figures and ``run.gif``, a video of it
  (``redservo animate``).

It ends with the list of what it wrote and the commands to look further
(``redservo view``, ``plot``, ``replay``).
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from pathlib import Path
from typing import Any, TextIO

from redservo.cli.entry import main


class _Tap:
    """A stream that notes the time of every write (the rest goes to the stream it wraps)."""

    def __init__(self, stream: TextIO, watch: Watch) -> None:
        self._stream, self._watch = stream, watch

    def write(self, text: str) -> int:
        self._watch.last = time.monotonic()
        return self._stream.write(text)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


class Watch:
    """While a step runs, say ``… still working on <what> (N s)`` on stderr whenever it has
    written nothing for ``every`` seconds: no silent stretch longer than that in make demo."""

    def __init__(self, what: str, every: float = 10.0) -> None:
        self.what, self.every = what, every
        self.last = self.start = time.monotonic()
        self.said = threading.Event()  # set once a line was printed (for the tests)
        self._stop = threading.Event()

    def _run(self, err: TextIO) -> None:
        while not self._stop.wait(self.every / 4):
            now = time.monotonic()
            if now - self.last >= self.every:
                err.write(f"  … still working on {self.what} ({now - self.start:.0f} s)\n")
                err.flush()
                self.last = now
                self.said.set()

    def __enter__(self) -> Watch:
        self._out, self._err = sys.stdout, sys.stderr
        sys.stdout, sys.stderr = _Tap(self._out, self), _Tap(self._err, self)
        self._thread = threading.Thread(target=self._run, args=(self._err,), daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        sys.stdout, sys.stderr = self._out, self._err


def _steps(out: Path) -> list[list[str]]:
    run = out / "panda-4points"
    return [
        ["reproduce", "--out", str(out)],
        [
            "campaign",
            "afma6-gaze-demo",
            "--samples",
            "12",
            "--seed",
            "0",
            "--out",
            f"{out}/campaign",
        ],
        ["run", "panda-4points", "--out", str(run), "-q"],
        ["animate", str(run), "--out", str(run / "run.gif"), "--frames", "60"],
    ]


def label(i: int, n: int, step: list[str]) -> str:
    """How the heartbeat lines name step ``i`` of ``n``: ``step 2/5 (redservo reproduce)``."""
    return f"step {i}/{n} (redservo {step[0]})"


def _count(root: Path, pattern: str) -> int:
    return sum(1 for _ in root.rglob(pattern))


def written(out: Path) -> list[str]:
    """What the demo wrote, one line each (paths relative to the working directory)."""
    run, camp = out / "panda-4points", out / "campaign"
    figures = [p for p in out.glob("*/*") if p.suffix in (".svg", ".png", ".pdf")]
    lines = [
        f"  {out / 'report.md'}  the reproduction report (claims, tables, figures)",
        f"  {out / 'report.json'}  the same, machine-readable",
        f"  {out}/<experiment>/  {len(figures)} figure files (SVG for the report, 300 dpi PNG)"
        f" and {_count(out, 'scenario.toml') - _count(camp, 'scenario.toml')} saved runs",
        f"  {camp / 'campaign.md'}  the campaign's statistics ({camp}/samples.csv, figures)",
        f"  {run}/  one run: scenario.toml, log.csv, summary.json, figures",
        f"  {run / 'run.gif'}  its animation (3-D scene, camera image, joints)",
    ]
    return lines


def run() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="out", help="output directory (default out/)")
    args = parser.parse_args()
    out = Path(args.out)
    steps = _steps(out)
    for i, step in enumerate(steps, 1):
        print(f"[{i}/{len(steps)}] $ redservo {' '.join(step)}", flush=True)
        with Watch(label(i, len(steps), step)):
            code = main(step)
        if code:
            return code
    run_dir = out / "panda-4points"
    print("\nThe demo wrote:")
    print("\n".join(written(out)))
    print(
        "\nLook further:\n"
        f"  redservo view {run_dir}        # interactive 3-D view in the browser\n"
        f"  redservo plot {out / 'campaign'} --format pdf   # re-draw figures from the files\n"
        f"  redservo replay {out / 'campaign'} --sample 0 --method gpm   # re-run one sample\n"
        f"  redservo run {run_dir / 'scenario.toml'}   # re-run the run exactly\n"
        "  redservo warmup   # compile the kernels once (a few minutes) for campaigns and long runs"
    )
    return 0


if __name__ == "__main__":
    sys.exit(run())
