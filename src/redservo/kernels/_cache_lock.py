"""One process at a time adds an entry to a numba cache index (POSIX ``flock``).

numba keeps one index per cached function (signature -> data file) and adds a compiled
signature by reading the index, adding the entry and writing the index back. Two processes
compiling *different* signatures of the same function at the same time (``redservo warmup
--jobs 2``, pytest-xdist workers, campaign workers on a cold cache) can both read the old
index: the last writer drops the other's entry, and both may pick the same data file name,
so that an entry can name the other signature's machine code. :func:`install` makes that
read-add-write one step across processes: an exclusive ``flock`` on :data:`LOCK_NAME` in the
cache directory is held while an entry is saved (milliseconds; loading takes no lock).
Without ``fcntl`` (Windows) nothing changes.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from typing import Any

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None  # type: ignore[assignment]

__all__ = ["LOCK_NAME", "install", "locked"]

LOCK_NAME = "redservo-index.lock"
"""The lock file, in the cache directory (numba's ``_cache_path``)."""


@contextlib.contextmanager
def locked(path: str) -> Iterator[None]:
    """Hold an exclusive ``flock`` on the file ``path`` (created if missing); without
    ``fcntl`` or a writable directory, no lock (numba's own behaviour)."""
    fd = -1
    if fcntl is not None:
        with contextlib.suppress(OSError):
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        if fd >= 0:
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        if fd >= 0:
            os.close(fd)  # releases the lock


def install(caching: Any) -> bool:
    """Make ``caching.IndexDataCacheFile.save`` (numba's index update) hold the lock;
    False when there is nothing to do (no ``fcntl``, numba's layout changed, done before)."""
    cls = getattr(caching, "IndexDataCacheFile", None)
    if fcntl is None or cls is None or getattr(cls, "_redservo_locked", False):
        return False
    save = cls.save

    def locked_save(self: Any, key: Any, data: Any) -> None:
        with locked(os.path.join(self._cache_path, LOCK_NAME)):
            save(self, key, data)

    cls.save = locked_save
    cls._redservo_locked = True
    return True
