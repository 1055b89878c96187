"""Compiled or plain kernels: what a command runs on when the kernel cache is cold.

The kernels are one source run two ways (:mod:`redservo.kernels._jit`): compiled by numba,
or as the plain Python/numpy functions they are written as, with the same numbers (the
reference path of the tests, ``tests/test_kernel_mode.py`` checks a whole run bit for bit).
Compiling costs about 40-70 CPU-seconds once per machine (then numba's on-disk cache
loads them in a few seconds); a short run on the plain functions costs about 1-2
CPU-seconds (``redservo run panda-4points``: 311 steps). So a command that runs a few
thousand steps is faster uncompiled until the cache is warm, and a campaign, a benchmark
or a real-time loop is not.

``REDSERVO_KERNELS`` chooses (docs/decisions.md, "First run"):

* ``auto`` (default): the commands of :data:`AUTO_COMMANDS` (``run``, ``compare``,
  ``reproduce``) run on the plain functions while the cache is cold, and say so in one
  line; compiled once ``redservo warmup`` has filled the cache (it leaves a marker there,
  :func:`mark_warm`). Every other command (``campaign``, ``bench``, ``servo``,
  ``replay``) and the Python API compile on first use, as always. ``replay`` re-runs a
  campaign's sample, which the campaign ran compiled: the two ways agree to a few ULP
  only, and a long ``predictive`` run can amplify that (mc05-joint-limits, seed 0,
  sample 22: 3e-15 rad at the first period, 0.03 rad at the 100th, converged in 323
  iterations compiled and at the 600-iteration cap plain), so a replay on a cold cache
  gave another row than its campaign;
* ``compiled``: always compile (the cold cache's cost is paid by the first command);
* ``python``: never compile (as ``REDSERVO_NO_NUMBA=1``).

The choice is made once per process, before any kernel is imported; the run's ``run.json``
records which it was (``"kernels"``). Nothing here imports numba until the cache is looked at.
"""

from __future__ import annotations

import hashlib
import os
import platform
import sys
from importlib.util import find_spec
from pathlib import Path

from redservo.errors import ConfigurationError

__all__ = [
    "AUTO_COMMANDS",
    "COLD_NOTICE",
    "MODES",
    "MODE_ENV",
    "cache_dir",
    "choose_for_command",
    "is_warm",
    "mark_warm",
    "requested_mode",
    "uncompiled_reason",
]

MODE_ENV = "REDSERVO_KERNELS"
"""Environment variable choosing compiled or plain kernels (module docstring)."""

MODES = ("auto", "compiled", "python")
"""Its allowed values."""

AUTO_COMMANDS = frozenset({"run", "compare", "reproduce"})
"""Commands that run uncompiled while the cache is cold under ``auto``: short jobs, for
which the plain functions cost less than compiling (module docstring). Not ``replay``: it
must give its campaign's row, computed compiled."""

COLD_NOTICE = (
    "redservo: the numba kernels are not compiled on this machine yet: running them as plain "
    "Python (the same numbers; `redservo warmup` compiles them once, a few minutes, for "
    "campaigns and long runs)"
)
"""The one line a command of :data:`AUTO_COMMANDS` prints when it runs uncompiled."""

_DISABLE_ENV = "REDSERVO_NO_NUMBA"  # redservo.kernels._jit.DISABLE_ENV (not imported: numba)
_KERNELS_DIR = Path(str(find_spec("redservo.kernels").origin)).resolve().parent  # type: ignore[union-attr]
_MARKER = "redservo-warm-{}.txt"


def requested_mode() -> str:
    """``REDSERVO_KERNELS``'s value (default ``auto``).

    Raises:
        ConfigurationError: not one of :data:`MODES` (``argument="REDSERVO_KERNELS"``).
    """
    mode = os.environ.get(MODE_ENV, "").strip().lower() or "auto"
    if mode not in MODES:
        raise ConfigurationError(
            f"{MODE_ENV} must be one of {', '.join(MODES)}, got {os.environ[MODE_ENV]!r}",
            argument=MODE_ENV,
        )
    return mode


def _stamp(numba_version: str) -> str:
    """A hash of every kernel module's source, numba's and Python's versions and the
    machine: a change of any of them makes the cache (and the marker) stale."""
    h = hashlib.sha256()
    for path in sorted(_KERNELS_DIR.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    h.update(f"{numba_version}|{sys.version}|{platform.machine()}".encode())
    return h.hexdigest()[:20]


def cache_dir() -> Path | None:
    """The directory numba caches the kernels in (numba's own choice: ``NUMBA_CACHE_DIR``,
    else ``__pycache__`` beside the kernels when writable, else the user's cache), or None
    without numba."""
    try:
        from numba.core import caching
    except ImportError:
        return None
    probe = str(_KERNELS_DIR / "control.py")
    for name in ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator"):
        cls = getattr(caching, name, None)
        loc = None if cls is None else cls.from_function(cache_dir, probe)
        if loc is not None:
            return Path(loc.get_cache_path())
    return None


def _marker() -> Path | None:
    try:
        import numba
    except ImportError:
        return None
    where = cache_dir()
    return None if where is None else where / _MARKER.format(_stamp(str(numba.__version__)))


def is_warm() -> bool:
    """Whether ``redservo warmup`` compiled every kernel into today's cache (its marker is
    there, for these sources, this numba, this Python and this machine)."""
    marker = _marker()
    return marker is not None and marker.is_file()


def mark_warm() -> Path | None:
    """Leave the marker of a complete warm-up in the cache (``redservo warmup`` calls it
    at its end); returns its path, or None without numba or a writable cache."""
    marker = _marker()
    if marker is None:
        return None
    try:
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.write_text("redservo warmup compiled every kernel into this cache\n")
    except OSError:
        return None
    return marker


def choose_for_command(command: str) -> tuple[str, bool]:
    """``("compiled" or "python", cold)``: what ``command`` runs on (module docstring), and
    whether it is uncompiled because the cache is cold (the command says so). With
    ``"python"`` it sets ``REDSERVO_NO_NUMBA=1`` for this process (and what it starts),
    before any kernel is imported; once a kernel is imported the choice is already made.

    Raises:
        ConfigurationError: ``REDSERVO_KERNELS`` is not one of :data:`MODES`.
    """
    mode = requested_mode()
    if "redservo.kernels._jit" in sys.modules:
        from redservo.kernels._jit import COMPILED

        return ("compiled" if COMPILED else "python"), False
    if os.environ.get(_DISABLE_ENV, "") not in ("", "0"):
        return "python", False
    cold = False
    if mode == "auto" and command in AUTO_COMMANDS:
        marker = _marker()
        cold = marker is not None and not marker.is_file()
    if mode == "python" or cold:
        os.environ[_DISABLE_ENV] = "1"
        return "python", cold
    return "compiled", False


def uncompiled_reason() -> str:
    """Why the kernels of this process run as plain Python (one line, for the records)."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return "numba is not installed (pip install 'redservo[fast]')"
    return (
        "the kernels run uncompiled in this process (REDSERVO_NO_NUMBA or REDSERVO_KERNELS="
        "python, or a cold kernel cache: `redservo warmup` compiles them)"
    )
