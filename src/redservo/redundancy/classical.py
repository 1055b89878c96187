"""The classical law without avoidance (CM01 eq. 2 with e = J1^+ e1)."""

from __future__ import annotations

from redservo.redundancy.base import Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.linalg import svd_events

__all__ = ["Classical"]


@register
class Classical(Law):
    """``q̇ = -λ J1^+ e1 - J1^+ ∂e1/∂t`` (CM01 eq. 2): no joint-limit avoidance.

    ``secondary``, if given, is projected with ``J1^⊥`` and added, as in the
    classical redundancy formalism (MC05 eq. 7).

    Options:
        rcond: relative singular-value cut-off of the pseudo-inverse.
    """

    name = "classical"
    description = "q̇ = -λ J1⁺ e1 (CM01 eq. 2): no avoidance"

    def compute(self, x: LawInputs) -> LawResult:
        svd = self.svd(x.J1)
        qdot = -x.lam * (svd.pinv @ x.e_eff)
        if x.secondary is not None:
            qdot = qdot + svd.null @ (svd.null.T @ x.secondary)
        m, n = x.J1.shape
        diag = Diagnostics(
            method=self.name,
            task_rank=svd.rank,
            rank_deficient=svd.rank < m,
            projector_rank=svd.null.shape[1] if x.secondary is not None else 0,
            events=tuple(
                e
                for e in svd_events(m, n, svd, self.filter_threshold)
                if e.flag.value != "no-redundancy"
            ),
        )
        return LawResult(qdot, diag)
