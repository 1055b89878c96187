"""The classical law without avoidance (CM01 eq. 2 with e = J1^+ e1)."""

from __future__ import annotations

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.redundancy.base import Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.flags import Event
from redservo.redundancy.kio import I_PROJ, I_RANK, LawOutputs, kernel_inputs, task_context
from redservo.redundancy.messages import events
from redservo.redundancy.safety import prev_command, safety_events

_K = lazy("calls")

__all__ = ["Classical"]

_NONE: FloatArray = np.zeros(0)
"""The outputs ``classical`` does not have (``axes``, ``axf``, ``vec``)."""


@register
class Classical(Law):
    """``q̇ = -λ J1^+ e1 - J1^+ ∂e1/∂t`` (CM01 eq. 2): no joint-limit avoidance.

    ``secondary``, if given, is projected with ``J1^⊥`` and added, as in the
    classical redundancy formalism (MC05 eq. 7).
    """

    name = "classical"
    description = "q̇ = -λ J1⁺ e1 (CM01 eq. 2): no avoidance"

    def compute(self, x: LawInputs) -> LawResult:
        k = kernel_inputs(x)
        thr = self.filter_threshold
        qdot, iout, fout, mask, vals, src = _K.classical_call(
            k.J1, k.e, x.lam, k.sec, k.has_sec, self.rcond, thr
        )
        none = _NONE
        out = LawOutputs(iout, fout, none, none, none, mask, vals, src)
        return LawResult(qdot, self.diagnose(x.J1.shape[0], out))

    def _compute_safe(self, x: LawInputs) -> LawResult | None:
        """The law and the safety stage in one kernel call (:meth:`Law._compute_safe`)."""
        if type(self).compute is not Classical.compute:  # a subclass computes otherwise
            return None
        k = kernel_inputs(x)
        prev, has_prev = prev_command(x.qdot_prev, x.J1.shape[1])
        out = _K.classical_safe_call(
            k.J1, k.e, x.lam, k.sec, k.has_sec, self.rcond, self.filter_threshold, k.q, k.lp,
            k.has_v, k.has_a, x.dt, prev, has_prev, self.shield,
        )  # fmt: skip
        qdot, joint, worst, mask, vals, src = out[5:]
        more = (
            safety_events(mask, vals, src, k.q, qdot, x.dt, x.limits, worst, joint) if mask else ()
        )
        iout, fout, lmask, lvals, lsrc = out[:5]
        none = _NONE
        law_out = LawOutputs(iout, fout, none, none, none, lmask, lvals, lsrc)
        return LawResult(qdot, self.diagnose(x.J1.shape[0], law_out, more))

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics from the kernel's outputs ``out`` (m task rows; ``more``: events to
        append, the safety layer's)."""
        iout = out.iout
        rank = int(iout[I_RANK])
        found: tuple[Event, ...] = ()
        if out.mask:
            ctx = task_context(m, iout, out.fout, self.filter_threshold)
            found = events(out.mask, out.vals, out.src, **ctx)
        return Diagnostics(
            method=self.name,
            task_rank=rank,
            rank_deficient=rank < m,
            projector_rank=int(iout[I_PROJ]),
            events=(*found, *more) if more else found,
        )
