"""Capture what C++ code prints on the process's standard error while it runs.

urdfdom (inside Pinocchio) reports a broken URDF by printing several raw lines such as
``Error:   joint [j1]: limit has no velocity`` / ``at line 205 in .../joint.cpp`` on file
descriptor 2 before Pinocchio raises its own one-line exception. :func:`captured_stderr`
redirects file descriptor 2 into a temporary file for the duration of a ``with`` block
(``os.dup``/``os.dup2``, so it also catches output that bypasses ``sys.stderr``), and
:func:`condense` turns the captured text into one short line to fold into our error.

The redirection is process-wide: a lock serialises the ``with`` blocks of this module,
and anything another thread prints on standard error meanwhile is captured too (the
caller passes it on, see :class:`~redservo.robots.URDFRobot`).
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["captured_stderr", "condense"]

_LOCK = threading.Lock()
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_WHERE = re.compile(r"^\s*at line \d+ in \S+\s*$")
_LEVEL = re.compile(r"^\s*(Error|Warning|Info|Debug):\s*", re.IGNORECASE)


@contextmanager
def captured_stderr() -> Iterator[list[str]]:
    """Redirect file descriptor 2 to a temporary file; the yielded list then holds its text.

    The list is empty inside the block and holds one string (possibly empty) after it.
    When file descriptor 2 cannot be duplicated (closed), nothing is captured.
    """
    out: list[str] = []
    with _LOCK:
        for stream in (sys.stderr, sys.__stderr__):
            try:
                if stream is not None:
                    stream.flush()
            except (OSError, ValueError):  # pragma: no cover - closed or broken stream
                pass
        try:
            saved = os.dup(2)
        except OSError:  # pragma: no cover - no file descriptor 2 at all
            yield out
            out.append("")
            return
        with tempfile.TemporaryFile() as tmp:
            os.dup2(tmp.fileno(), 2)
            try:
                yield out
            finally:
                os.dup2(saved, 2)
                os.close(saved)
                tmp.seek(0)
                out.append(tmp.read().decode("utf-8", errors="replace"))


def condense(text: str, limit: int = 400) -> str:
    """One line from a parser's output: no colours, no "at line N in file.cpp", "; "-joined.

    Args:
        text: What the parser printed.
        limit: Largest length of the result (characters); longer text ends with "...".
    """
    lines = []
    for raw in _ANSI.sub("", text).splitlines():
        if not raw.strip() or _WHERE.match(raw):
            continue
        line = " ".join(_LEVEL.sub("", raw).split())
        if line and line not in lines:
            lines.append(line)
    joined = "; ".join(lines)
    return joined if len(joined) <= limit else joined[: limit - 3] + "..."
