"""The classical law without avoidance (CM01 eq. 2 with e = J1^+ e1)."""

from __future__ import annotations

from redservo.kernels import lazy
from redservo.redundancy.base import Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.flags import Event
from redservo.redundancy.kio import kernel_inputs, task_names
from redservo.redundancy.messages import events

_K = lazy("calls")

__all__ = ["Classical"]


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
        qdot, rank, proj, filtered, cond, mask, vals, src = _K.classical_call(
            k.J1, k.e, x.lam, k.sec, k.has_sec, self.rcond, thr
        )
        m = x.J1.shape[0]
        found: tuple[Event, ...] = ()
        if mask:
            found = events(mask, vals, src, **task_names(m, rank, cond, filtered, thr))
        diag = Diagnostics(
            method=self.name,
            task_rank=rank,
            rank_deficient=rank < m,
            projector_rank=proj,
            events=found,
        )
        return LawResult(qdot, diag)
