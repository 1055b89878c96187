"""A compiled kernel's machine-code entry for argument types known in advance (hot paths).

Calling a numba kernel through its dispatcher types every argument (the step kernels take
25-30 arrays and numbers in nested tuples) and looks the types up among the compiled
versions, on every call. A caller that builds the arguments itself knows their types: after
one call through the dispatcher (which compiles or loads the version), :func:`entry_of`
finds that version's entry point, the very function the dispatcher would call; the caller
then calls it directly for as long as its arguments keep those types (the caller's own
checks, :func:`plain`), and goes through the dispatcher otherwise. The numbers are the same
bit for bit (the same machine code). Without numba (``REDSERVO_NO_NUMBA``, the uncompiled
kernel mode) a kernel has no compiled versions and :func:`entry_of` gives None.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["entry_of", "plain"]

_F64 = np.dtype(np.float64)


def plain(a: Any) -> bool:
    """``a`` is a 1-D float64 array that numba types as the step kernels' arrays
    (``Array(float64, 1, 'C')``: C-contiguous, aligned, writeable), so an entry found for
    such an array takes it."""
    return type(a) is np.ndarray and a.dtype == _F64 and a.ndim == 1 and a.flags.carray


def entry_of(kernel: Any, args: tuple[Any, ...]) -> Callable[..., Any] | None:
    """The entry point of ``kernel``'s compiled version for the types of ``args`` (as the
    entry takes them: a ``*packs`` parameter as one tuple), or None when there is none (not
    a numba dispatcher, or no version compiled for exactly these types yet)."""
    overloads = getattr(kernel, "overloads", None)
    if not isinstance(overloads, dict):
        return None
    try:
        from numba import typeof

        found = overloads.get(tuple(typeof(a) for a in args))
    except (TypeError, ValueError):  # a value numba cannot type: keep the dispatcher
        return None
    entry = getattr(found, "entry_point", None)
    return entry if callable(entry) else None
