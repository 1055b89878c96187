"""The classical law without avoidance (CM01 eq. 2 with e = J1^+ e1)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.redundancy.base import Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.flags import Event
from redservo.redundancy.kio import kernel_inputs, task_names
from redservo.redundancy.messages import events
from redservo.redundancy.safety import prev_command, safety_events

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
        qdot, *task = _K.classical_call(k.J1, k.e, x.lam, k.sec, k.has_sec, self.rcond, thr)
        return LawResult(qdot, self._diagnostics(x, *task))

    def _compute_safe(self, x: LawInputs) -> LawResult | None:
        """The law and the safety stage in one kernel call (:meth:`Law._compute_safe`)."""
        if type(self).compute is not Classical.compute:  # a subclass computes otherwise
            return None
        k = kernel_inputs(x)
        prev, has_prev = prev_command(x.qdot_prev, x.J1.shape[1])
        out = _K.classical_safe_call(
            k.J1,
            k.e,
            x.lam,
            k.sec,
            k.has_sec,
            self.rcond,
            self.filter_threshold,
            k.q,
            k.lp,
            k.has_v,
            k.has_a,
            x.dt,
            prev,
            has_prev,
            self.shield,
        )
        qdot, joint, worst, mask, vals, src = out[7:]
        more = (
            safety_events(mask, vals, src, k.q, qdot, x.dt, x.limits, worst, joint) if mask else ()
        )
        rank, proj, filtered, cond, lmask, lvals, lsrc = out[:7]
        diag = self._diagnostics(x, rank, proj, filtered, cond, lmask, lvals, lsrc, more)
        return LawResult(qdot, diag)

    def _diagnostics(
        self,
        x: LawInputs,
        rank: int,
        proj: int,
        filtered: int,
        cond: float,
        mask: int,
        vals: FloatArray,
        src: NDArray[np.int64],
        more: tuple[Event, ...] = (),
    ) -> Diagnostics:
        """The diagnostics from the fused kernel's numbers, then the events ``more``."""
        m = x.J1.shape[0]
        found: tuple[Event, ...] = ()
        if mask:
            found = events(
                mask, vals, src, **task_names(m, rank, cond, filtered, self.filter_threshold)
            )
        return Diagnostics(
            method=self.name,
            task_rank=rank,
            rank_deficient=rank < m,
            projector_rank=proj,
            events=(*found, *more) if more else found,
        )
