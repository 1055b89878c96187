"""An exclusive lock on a campaign's output directory, and workers that die with their parent.

:class:`DirectoryLock` holds ``DIR/.lock`` for as long as a campaign writes to ``DIR``: a
second process gets a :class:`~redservo.errors.ConfigurationError` naming the holder's pid,
or waits (``wait=True``, ``redservo campaign --wait``). The lock is a POSIX record lock
(``fcntl.lockf``): the kernel releases it when the holder dies, however it dies, and it is
not inherited by the worker processes. Within one process a registry gives the same
exclusion (POSIX locks do not exclude their own process). On Windows ``msvcrt.locking``
plays the same role.

:func:`worker_init` is the initializer of the campaign's process pool: on Linux the worker
asks the kernel for SIGKILL when its parent dies (``prctl(PR_SET_PDEATHSIG)``), and on every
platform a watchdog thread exits the worker when its parent is gone, so killing a
campaign (even with SIGKILL) leaves no orphan workers.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path
from types import TracebackType

from redservo.errors import ConfigurationError

__all__ = ["DirectoryLock", "worker_init"]

_HELD: set[str] = set()
_HELD_GUARD = threading.Lock()
_POLL_S = 0.2
"""How often a waiting process retries the lock, and the workers check their parent (s)."""


def _try_lock(fd: int) -> bool:
    """Take the exclusive lock on ``fd`` without blocking; False when another process holds it."""
    if sys.platform == "win32":  # pragma: no cover - exercised on Windows only
        import msvcrt

        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            return False
        return True
    import errno
    import fcntl

    try:
        fcntl.lockf(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        if exc.errno in (errno.EACCES, errno.EAGAIN):
            return False  # held by another process
        raise ConfigurationError(
            f"cannot lock the output directory ({exc.strerror}); a file system without locks? "
            "use a local directory",
            argument="out",
        ) from None
    return True


class DirectoryLock:
    """Exclusive lock on an output directory (``DIR/.lock``); a context manager.

    Args:
        directory: The directory (created if needed).
        wait: Wait for the holder to finish instead of raising.
        notify: Called once with a message when waiting starts (e.g. print to stderr).

    Raises:
        ConfigurationError: another process (or another campaign in this process) holds the
            lock and ``wait`` is False.
    """

    def __init__(
        self, directory: Path, *, wait: bool = False, notify: object | None = None
    ) -> None:
        self.directory = Path(directory)
        self.path = self.directory / ".lock"
        self._key = str(self.directory.resolve())
        self._fd: int | None = None
        self.directory.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            self._acquire(fd, wait, notify)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())

    def _holder(self) -> str:
        try:
            pid = self.path.read_text().strip()
        except OSError:
            pid = ""
        return f"pid {pid}" if pid else "another process"

    def _acquire(self, fd: int, wait: bool, notify: object | None) -> None:
        told = False
        while True:
            with _HELD_GUARD:
                if self._key not in _HELD and _try_lock(fd):
                    _HELD.add(self._key)
                    return
            if not wait:
                raise ConfigurationError(
                    f"{self.directory} is in use by another redservo campaign "
                    f"({self._holder()}); wait for it to finish, or rerun with --wait "
                    "(run_campaign(wait=True)), or use another output directory",
                    argument="out",
                )
            if not told and callable(notify):
                notify(f"waiting for {self._holder()} to release {self.directory} ...")
                told = True
            time.sleep(_POLL_S)

    def release(self) -> None:
        """Release the lock (idempotent); the lock file stays."""
        if self._fd is None:
            return
        with _HELD_GUARD:
            _HELD.discard(self._key)
            os.close(self._fd)  # closing the descriptor releases the POSIX lock
            self._fd = None

    def __enter__(self) -> DirectoryLock:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.release()


def _parent_gone(parent: int, ppid0: int) -> bool:
    if os.getppid() != ppid0:
        return True  # re-parented: the parent died
    try:
        os.kill(parent, 0)
    except ProcessLookupError:
        return True
    except OSError:  # pragma: no cover - no permission: it exists
        return False
    return False


def _watch(parent: int, ppid0: int) -> None:
    while not _parent_gone(parent, ppid0):
        time.sleep(_POLL_S)
    os._exit(1)


def worker_init(parent: int) -> None:
    """Pool initializer: make this worker process exit as soon as ``parent`` (a pid) dies."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            import signal

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG = 1
        except (OSError, AttributeError):  # pragma: no cover - exotic libc
            pass
    ppid0 = os.getppid()
    if _parent_gone(parent, ppid0):  # the parent died before prctl took effect
        os._exit(1)
    threading.Thread(target=_watch, args=(parent, ppid0), daemon=True).start()
