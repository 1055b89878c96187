"""The measured inverse depths into the compiled engine's buffer, at every quick step.

:func:`redservo.control.engine.quick_step` hands the kernel the points' inverse depths
(1/m) as one (N,) float64 array, the engine's :attr:`~redservo.binding.control.CompiledControl.iz_buffer`,
written in place from the measurement's N entries. The object path takes N entries of
one number each ((1,) arrays of integers or floats, what its
:meth:`~redservo.task.VisualTask.evaluate_measured` checks); anything else makes the quick
step return None, so the full path raises the object path's error naming the entry.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from redservo.binding.control import CompiledControl

__all__ = ["take_inverse_depths"]

_ND = np.ndarray
_F64 = np.dtype(np.float64)


def take_inverse_depths(eng: CompiledControl, inv_depth: Any) -> bool:
    """Write the points' inverse depths ``inv_depth`` (N entries, 1/m) into
    ``eng.iz_buffer``, or False when they are not N entries of one number each. N (1,)
    float64 arrays (the common case, checked entry by entry) are copied byte for byte;
    anything else (lists, float32 or integer arrays) goes through numpy's conversion,
    refusing what is not an (N, 1) block of integers or floats (booleans, objects,
    complex numbers: the object path refuses them too)."""
    try:
        if len(inv_depth) != eng.iz_shape[0]:
            return False
        for d in inv_depth:
            if type(d) is not _ND or d.ndim != 1 or len(d) != 1 or d.dtype is not _F64:
                return _converted(eng, inv_depth)
        eng.iz_bytes[:] = b"".join(inv_depth)
    except (TypeError, ValueError):
        return False
    return True


def _converted(eng: CompiledControl, inv_depth: Any) -> bool:
    """:func:`take_inverse_depths` through numpy's conversion (entries that are not (1,)
    float64 arrays)."""
    rows = np.asarray(inv_depth)
    if rows.shape != eng.iz_rows.shape or rows.dtype.kind not in "iuf":
        return False
    eng.iz_rows[:] = rows
    return True
