"""The worked extension examples run compiled, in one numba cache of their own.

``examples/custom_law_damped.py`` (a law) and ``examples/scara_robot.py`` (a robot kind)
each add a branch to a generated dispatch (laws, robot kinds), which is part of the cache
stamp of every step that calls it: a process with either extension compiles its own step
chain, which must not overwrite the test session's cache. Both run here in processes that
declare both extensions (each example is still one file), so they share one compiled chain
in :data:`CACHE` instead of compiling two (about 150-190 CPU-s each on a cold cache).

Only the kernels that call the extended dispatch differ from the package's: :func:`seed`
first copies the package's warm cache (``redservo warmup``'s, in ``__pycache__`` beside the
kernels) into :data:`CACHE`, so that the examples load every other kernel (numba checks each
entry's source stamp and recompiles a stale one, in :data:`CACHE` only).

:func:`run_example` seeds :data:`CACHE` first (seconds; nothing copied twice), so the first
of the two tests that run the examples (one xdist group) compiles the chain and the second
loads it: ``make test`` compiles it that way, on one pytest worker while the other runs tests,
after the warm-up. ``python -m tests.examples_cache`` (``make warm-examples``) compiles it
ahead of the tests; a warm cache takes seconds.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
CACHE = EXAMPLES / "__pycache__" / "numba-examples"
"""The examples' numba cache (gitignored with ``__pycache__``)."""
NAMES = ("custom_law_damped", "scara_robot")
PACKAGE_KERNELS = (ROOT / "src" / "redservo" / "kernels", ROOT / "src" / "redservo" / "campaign")
"""The directories of the package's cached kernels (their ``__pycache__``)."""


def seed(cache: Path = CACHE, sources: tuple[Path, ...] = PACKAGE_KERNELS) -> int:
    """Copy each source directory's numba cache files (``__pycache__/*.nbi``, ``*.nbc``) to
    where numba looks for them under ``NUMBA_CACHE_DIR=cache`` (its
    ``UserProvidedCacheLocator``: ``<dir name>_<sha1 of the dir path>``), without replacing
    a file already there; returns how many were copied."""
    copied = 0
    for src in sources:
        where = str(src.resolve())
        dest = cache / f"{src.name}_{hashlib.sha1(where.encode()).hexdigest()}"
        for f in sorted((src / "__pycache__").glob("*.nb[ic]")):
            if not (dest / f.name).exists():
                dest.mkdir(parents=True, exist_ok=True)
                shutil.copy2(f, dest / f.name)
                copied += 1
    return copied


def run_example(name: str) -> subprocess.CompletedProcess[str]:
    """Run ``examples/<name>.py --quick`` compiled, in a process that declares both
    extensions, with :data:`CACHE` (seeded: :func:`seed`) as its numba cache."""
    seed(CACHE, PACKAGE_KERNELS)
    code = (
        "import sys\n"
        f"sys.path.insert(0, {str(EXAMPLES)!r})\n"
        f"import {', '.join(NAMES)}\n"
        f"sys.exit({name}.main(['--quick']))\n"
    )
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT / "src"),
        "NUMBA_CACHE_DIR": str(CACHE),
        "REDSERVO_KERNELS": "compiled",
    }
    return subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False
    )


def main() -> int:
    """Compile the examples' chain (one line per example), after seeding :data:`CACHE`."""
    print(f"== examples: {seed()} package kernel cache files copied to share", flush=True)
    for name in NAMES:
        print(f"== examples: {name} --quick, compiled into {CACHE.relative_to(ROOT)}", flush=True)
        done = run_example(name)
        if done.returncode != 0:
            print(done.stdout + done.stderr, file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
