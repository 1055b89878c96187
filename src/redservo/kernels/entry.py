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

A hot path's kernel writes its results into arrays the caller made (numba boxes every array
a kernel returns, ≈ 0.4 µs apiece; a new ``np.empty`` costs 0.13-0.2 µs): :class:`Spares`
keeps two sets of them and hands out one that nothing outside holds any more (its arrays'
reference counts), so that a loop keeping the previous call's results while it makes the
next call gets the other set, and a result a caller keeps never changes under it.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["Spares", "entry_of", "plain"]

_F64 = np.dtype(np.float64)
_refs = sys.getrefcount
_empty = np.empty


class Spares:
    """Two sets of output arrays of the shapes ``shapes`` for a kernel to write into, each
    handed out again only when no one else holds any of its arrays (module docstring).

    ``views``: a function of a set's arrays returning a tuple of views of them, made once
    with the set; the set is then ``(*arrays, views, *views)``, the views and their tuple
    handed out as they are (a task's per-term (1,) inverse depths: no new views per call)
    and counted as members of the set, so a caller holding any of them holds the set.

    :meth:`take` returns the set that was not handed out last when it is free, else the
    other when it is free, else a new set in place of the older one (whose arrays are then
    the caller's alone). Reuse changes no number: the kernel writes every element of the
    set it is given before anything reads it. A copy (``copy``, ``pickle``) has sets of its
    own. A caller never hands out the set's own tuple (the arrays in it would not count
    as held)."""

    __slots__ = ("free", "last", "sets", "shapes", "views")

    def __init__(
        self,
        shapes: tuple[tuple[int, ...], ...],
        views: Callable[[tuple[Any, ...]], tuple[Any, ...]] | None = None,
    ) -> None:
        self.shapes, self.views = shapes, views
        self.sets = [self._new(), self._new()]
        self.last = 0
        got = self.sets[0]
        self.free = _refs(got) + sum(map(_refs, got))
        """The reference counts of a set and its members when only this object holds them
        (and :meth:`take`'s own binding, counted the same way)."""

    def _new(self) -> tuple[Any, ...]:
        arrays = tuple(_empty(shape) for shape in self.shapes)
        if self.views is None:
            return arrays
        views = self.views(arrays)
        return (*arrays, views, *views)

    def take(self) -> tuple[Any, ...]:
        """A set nothing outside holds (class docstring). The set is bound before its
        reference counts are read, and the set's own count is among them: two threads
        calling at once never both find the same set free (each sees the other's binding),
        at worst both make a new one."""
        sets, i = self.sets, 1 - self.last
        got = sets[i]
        if _refs(got) + sum(map(_refs, got)) != self.free:
            i = self.last
            got = sets[i]
            if _refs(got) + sum(map(_refs, got)) != self.free:
                i = 1 - i
                got = sets[i] = self._new()
        self.last = i
        return got

    def __reduce__(self) -> tuple[Any, ...]:
        """A copy has fresh arrays (never those of the original)."""
        return (Spares, (self.shapes, self.views))


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
