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

**Cache invalidation.** numba keys a cached function on its own source file only, so a
kernel calling a kernel of another module would keep running the callee's old machine
code after an edit of that module. The kernels therefore use cache locators whose source
stamp is a hash of the module *and of every kernel module it imports*, directly or not:
an edit recompiles the kernels that may call the edited code (docs/speed.md gives the
cost), and a stale cache is never loaded.
"""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from redservo.kernels import _cache_lock

__all__ = ["COMPILED", "DISABLE_ENV", "add_stamp", "kernel", "numba_version"]

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


_KERNELS_DIR = Path(__file__).resolve().parent


_IMPORTS = re.compile(r"^from redservo\.kernels\.(\w+) import", re.MULTILINE)
_STAMPS: dict[str, str] = {}
_EXTRA: dict[str, bytes] = {}


def add_stamp(module: str, data: bytes) -> None:
    """Make ``data`` part of the cache stamp of the kernel module ``module`` and of every
    kernel module importing it: the source of the code ``module`` generates
    (:mod:`redservo.kernels.law_dispatch`), so that cached callers are recompiled when it
    changes. Call it before the kernels that read the stamp are defined."""
    _EXTRA[module] = data
    _STAMPS.clear()


def _closure(name: str) -> list[str]:
    """The kernel modules ``name`` imports, directly or not, itself included (sorted)."""
    seen: set[str] = set()
    todo = [name]
    while todo:
        mod = todo.pop()
        if mod in seen:
            continue
        seen.add(mod)
        path = _KERNELS_DIR / f"{mod}.py"
        if path.is_file():
            todo.extend(_IMPORTS.findall(path.read_text(encoding="utf-8")))
    return sorted(seen)


def _stamp(py_file: str) -> str:
    """A hash of the source of the module ``py_file`` and of every kernel module it imports."""
    name = Path(py_file).stem
    hit = _STAMPS.get(name)
    if hit is None:
        h = hashlib.sha256()
        for mod in _closure(name):
            path = _KERNELS_DIR / f"{mod}.py"
            h.update(mod.encode())
            h.update(path.read_bytes() if path.is_file() else b"")
            h.update(_EXTRA.get(mod, b""))
        hit = _STAMPS[name] = h.hexdigest()
    return hit


def _install_locators(numba: Any) -> None:
    """Put cache locators stamped with the imported kernel modules first, for this package."""
    try:
        from numba.core import caching
    except ImportError:  # pragma: no cover - numba's layout changed: plain per-file stamps
        return
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    bases = [
        getattr(caching, name, None)
        for name in ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")
    ]
    if impl is None or any(b is None for b in bases) or getattr(impl, "_redservo", False):
        return

    def stamped(base: Any) -> Any:
        class Locator(base):
            _redservo_stamp = ""

            @classmethod
            def from_function(cls, py_func: Any, py_file: str) -> Any:
                if Path(py_file).resolve().parent != _KERNELS_DIR:
                    return None
                self = super().from_function(py_func, py_file)
                if self is not None:
                    self._redservo_stamp = _stamp(py_file)
                return self

            def get_source_stamp(self) -> str:
                return self._redservo_stamp

        Locator.__name__ = f"RedservoPackage{base.__name__}"
        return Locator

    impl._locator_classes = [*(stamped(b) for b in bases), *impl._locator_classes]
    impl._redservo = True
    _cache_lock.install(caching)  # concurrent compilers keep every index entry


_NUMBA = _load_numba()
if _NUMBA is not None:
    _install_locators(_NUMBA)

COMPILED: bool = _NUMBA is not None
"""True when the kernels are compiled by numba (False: plain Python/numpy functions)."""


def numba_version() -> str | None:
    """The numba version compiling the kernels, or None on the reference path."""
    return None if _NUMBA is None else str(_NUMBA.__version__)


def kernel(fn: F) -> F:
    """Compile ``fn`` with ``numba.njit(cache=True, nogil=True)``, or return it unchanged.

    The compiled dispatcher keeps the plain function as ``.py_func``. Compiled code is
    cached on disk (``__pycache__`` next to the source), so the compile cost is paid once
    per machine and signature (docs/speed.md gives the numbers). A kernel called by another
    kernel is compiled for the plain types of the arguments (:func:`_plain_calls`).
    """
    if _NUMBA is None:
        return fn
    compiled: F = _NUMBA.njit(cache=True, nogil=True)(fn)
    _plain_calls(compiled)
    return compiled


def _plain_calls(dispatcher: Any) -> None:
    """Type a call from another kernel with its arguments' plain types (``int64``, ``bool``),
    not numba's literal types of the constants written at the call site (``Literal[int](3)``):
    numba would compile one specialisation per distinct constant (30 of ``events._raise``,
    one per flag value elsewhere) where one serves them all, with the same numbers (the same
    code; the constant is an argument instead of folded in). Calls from Python already
    pass plain types."""
    from numba.core import types

    template = dispatcher.get_call_template

    def get_call_template(args: tuple[Any, ...], kws: dict[str, Any]) -> Any:
        plain = {k: types.unliteral(v) for k, v in kws.items()}
        return template(tuple(types.unliteral(a) for a in args), plain)

    dispatcher.get_call_template = get_call_template
