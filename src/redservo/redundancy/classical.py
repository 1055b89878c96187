"""The classical law without avoidance (CM01 eq. 2 with e = J1^+ e1)."""

from __future__ import annotations

from redservo.kernels import lazy
from redservo.redundancy.base import Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.kio import I_PROJ, I_RANK, kernel_inputs, task_context
from redservo.redundancy.messages import events

_K = lazy("laws")
_KE = lazy("events")

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
        qdot, iout, fout, _, _, _ = _K.classical(
            k.J1, k.e, x.lam, k.sec, k.has_sec, self.rcond, self.filter_threshold
        )
        m, n = x.J1.shape
        rank = int(iout[I_RANK])
        thr = self.filter_threshold
        mask, vals, src = _KE.classical_events(m, n, iout, thr)
        diag = Diagnostics(
            method=self.name,
            task_rank=rank,
            rank_deficient=rank < m,
            projector_rank=int(iout[I_PROJ]),
            events=events(mask, vals, src, **task_context(m, iout, fout, thr)) if mask else (),
        )
        return LawResult(qdot, diag)
