"""The :class:`~redservo.Diagnostics` every kernel-backed law builds from its kernel's outputs.

A law's ``diagnose(m, out, more)`` reads the kernel's named outputs
(:class:`~redservo.redundancy.kio.LawOutputs`) into the public diagnostics: the task rank
(CM01 eq. 25's ``J1``, of ``m`` rows), whether it is rank deficient, the projector's rank,
the kernel's flags worded as events followed by the safety layer's ``more``, and what the
law adds of its own (critical axes, α, iterations, information lines). The part common to
every law is written here once; a law passes only its own fields.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from redservo.redundancy.base import Diagnostics
from redservo.redundancy.kio import I_PROJ, I_RANK, LawOutputs, task_context
from redservo.redundancy.messages import events

if TYPE_CHECKING:
    from redservo.redundancy.base import Law
    from redservo.redundancy.flags import Event

__all__ = ["kernel_diagnostics"]


def kernel_diagnostics(
    law: Law,
    m: int,
    out: LawOutputs,
    more: tuple[Event, ...] = (),
    context: Callable[[], dict[str, Any]] | None = None,
    **fields: Any,
) -> Diagnostics:
    """The diagnostics of ``law``'s kernel call with outputs ``out`` for a task of ``m`` rows.

    ``more``: the safety layer's events, appended after the law's own. ``context``: the
    numbers the law's messages name, called only when the kernel raised a flag (default:
    the task inverse's, :func:`~redservo.redundancy.kio.task_context` with the law's
    ``filter_threshold``). ``fields``: the law's own :class:`~redservo.Diagnostics` fields
    (a ``task_rank`` given here replaces the kernel's ``iout[I_RANK]``).
    """
    rank = fields.pop("task_rank", None)
    rank = int(out.iout[I_RANK]) if rank is None else rank
    found: tuple[Event, ...] = ()
    if out.mask:
        ctx = (
            context()
            if context is not None
            else task_context(m, out.iout, out.fout, law.filter_threshold)
        )
        found = events(out.mask, out.vals, out.src, **ctx)
    return Diagnostics(
        method=law.name,
        task_rank=rank,
        rank_deficient=rank < m,
        projector_rank=int(out.iout[I_PROJ]),
        events=(*found, *more) if more else found,
        **fields,
    )
