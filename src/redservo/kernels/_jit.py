"""The :func:`kernel` decorator: one source, compiled by numba when it is installed.

``kernel(fn)`` returns ``numba.njit(cache=True, nogil=True)(fn)`` when numba imports
(optional extra ``redservo[fast]``) and ``fn`` itself otherwise, so that the very same
function body is the compiled kernel and the reference implementation
(``compiled.py_func`` is the plain function). Setting the environment variable
``REDSERVO_NO_NUMBA=1`` before the first kernel module is imported forces the plain
functions (the reference path of ``redservo bench`` and of the tests).

The kernels follow rules that keep both paths identical (docs/speed.md):

* inputs are C-contiguous float64 arrays, Python floats, ints and bools; optional
  arrays are passed as a dummy array plus a ``has_...`` flag (numba has no None);
* outputs are fresh arrays and scalars; diagnostics are integer codes and numbers that
  the Python layer turns into typed results and messages;
* no division whose divisor may be a Python float equal to zero (plain Python raises
  where numba returns inf), no exceptions, no Python objects.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["COMPILED", "DISABLE_ENV", "kernel", "numba_version"]

DISABLE_ENV = "REDSERVO_NO_NUMBA"
"""Environment variable: a non-empty value other than ``0`` disables compilation."""

F = TypeVar("F", bound=Callable[..., Any])


def _load_numba() -> Any | None:
    if os.environ.get(DISABLE_ENV, "") not in ("", "0"):
        return None
    try:
        import numba
    except ImportError:
        return None
    return numba


_NUMBA = _load_numba()

COMPILED: bool = _NUMBA is not None
"""True when the kernels are compiled by numba (False: plain Python/numpy functions)."""


def numba_version() -> str | None:
    """The numba version compiling the kernels, or None on the reference path."""
    return None if _NUMBA is None else str(_NUMBA.__version__)


def kernel(fn: F) -> F:
    """Compile ``fn`` with ``numba.njit(cache=True, nogil=True)``, or return it unchanged.

    The compiled dispatcher keeps the plain function as ``.py_func``. Compiled code is
    cached on disk (``__pycache__`` next to the source), so the compile cost is paid once
    per machine and signature (docs/speed.md gives the numbers).
    """
    if _NUMBA is None:
        return fn
    compiled: F = _NUMBA.njit(cache=True, nogil=True)(fn)
    return compiled
