"""The sizes of a law's option packs and the slots every law shares (no numba: importing is free).

:func:`redservo.kernels.step.law_step` takes a law's options as ``fopt`` (float64),
``iopt`` (int64) and ``vopt`` ((2, n) float64, per-joint rows, inf when absent). The slots
common to every law are below; a law's own options and packed extras get theirs, in
declaration order, from :func:`redservo.redundancy.options.slotted`, and the generated
dispatch (:mod:`redservo.kernels.law_dispatch`) reads them by the names the law declares
(``KERNEL``, :class:`redservo.redundancy.declare.LawKernel`). No other slot is numbered by
hand.
"""

from __future__ import annotations

__all__ = ["F_RCOND", "F_ROBUST", "I_FIRST", "I_SHIELD", "NF", "NI"]

NF, NI = 8, 4
"""Sizes of ``fopt`` and ``iopt``."""

F_RCOND, F_ROBUST = 0, 1
"""rcond; the robust filter threshold ε of the task inverse (0 when ``robust`` is off)."""
I_SHIELD, I_FIRST = 0, 1
"""The position shield; secondary-first scaling."""
