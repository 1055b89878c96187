"""The classical law without avoidance (CM01 eq. 2 with e = J1^+ e1)."""

from __future__ import annotations

import numpy as np

from redservo._validation import FloatArray
from redservo.redundancy.base import Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.declare import LawKernel
from redservo.redundancy.flags import Event
from redservo.redundancy.kernel_call import kernel_compute
from redservo.redundancy.kio import LawOutputs
from redservo.redundancy.law_diagnostics import kernel_diagnostics

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
    KERNEL = LawKernel(
        "redservo.kernels.laws:classical",
        "J1 e lam sec has_sec opt.rcond opt.robust",
        "redservo.kernels.events:classical_events",
        "m n iout opt.robust",
    )

    def compute(self, x: LawInputs) -> LawResult:
        """The raw command and diagnostics: the law kernel of the step kernel
        (:func:`~redservo.redundancy.kernel_call.kernel_compute`)."""
        return LawResult(*kernel_compute(self, x))

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics from the kernel's outputs ``out`` (m task rows; ``more``: events to
        append, the safety layer's)."""
        return kernel_diagnostics(self, m, out, more)
