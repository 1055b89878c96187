"""Gradient projection with the CM01 joint-limit cost, fixed or automatic gain (CM01 §II).

``gpm`` (CM01 eqs. 1-6)::

    q̇ = -λ (J1⁺ e1 + α J1^⊥ e2) + J1^⊥ secondary

with ``e2 = (∂h_s/∂q)^T`` the gradient of the joint-limit cost of eqs. 4-6
(:meth:`~redservo.JointLimits.gradient`), evaluated at the current ``q``.
``e1`` is the effective error ``e1 + ∂e1/∂t / λ`` throughout (base.py), so the
feed-forward of eq. 2 is included and ``J1 q̇ = -λ e1 - ∂e1/∂t``.

``gpm-auto`` (CM01 eqs. 7-9) computes α at every step to stop the most critical
axis, with eq. 9 corrected to ``α = -(J1⁺e1)_k / (J1^⊥ e2)_k`` (docs/formulas.md
§6.2; the printed ``J1⁺ e2`` is not even defined).

Decisions (the paper is silent or ambiguous; listed for docs/decisions.md):

* ``gpm`` default ``alpha = 2.0``: the smallest gain with which CM01's point
  experiment succeeded (§V-A2: fails with 1.5, succeeds with α ≥ 2).
* Critical axis of ``gpm-auto``: predict ``q̂ = q - λ dt w`` (eq. 8) with
  ``w = J1⁺e1 - J1^⊥ secondary / λ`` (the motion the law would produce with
  α = 0). The candidates are the critical axes of docs/formulas.md §7.2
  (:meth:`~redservo.JointLimits.critical`: ``q̂_k`` in the band or beyond, and
  moving toward that limit). Among them k is the one whose ``q̂_k`` is closest to
  its limit *as a fraction of the axis range*
  (:meth:`~redservo.JointLimits.margin`), so that prismatic (m) and revolute
  (rad) axes compare. α is then ``-w_k / (J1^⊥ e2)_k`` so that ``q̇_k = 0``
  exactly, also when a ``secondary`` command is given.
* Degenerate cases of ``gpm-auto`` (each reported in ``diagnostics.notes``;
  ``critical`` is ``((k,),)`` only when a positive α is applied):

  - no critical axis: α = 0 (classical law);
  - ``|(J1^⊥ e2)_k| <= 1e-10 max|e2|`` (in particular ``e2 = 0``, when ``q_k``
    is still outside the band and only ``q̂_k`` enters it, or no redundancy):
    α is undefined, α = 0;
  - α < 0 (the projected gradient pushes axis k the same way as the task): α = 0,
    because a negative gain would drive the axes already in the band deeper
    toward their limits;
  - ``alpha_max`` (default ``None``: no cap, so the large-gain transient that CM01
    Fig. 10(c) reports is reproduced) caps α; axis k is then only slowed.

  Only one axis is ever stopped (CM01 §II-C); other critical axes are listed in
  a note.
* ``critical_rule`` of ``gpm-auto`` (docs/formulas.md §6.2, §7.2): ``"predicted"``
  (default) takes the candidates from ``q̂`` as above; ``"current"`` is CM01 §II-C's
  text read literally: an axis is a candidate when its *current* position ``q_k``
  lies between its threshold and its limit (or beyond) and it moves toward that
  limit (``q̂_k`` nearer the limit than ``q_k``); among them k is still the one
  whose ``q̂_k`` is closest to its limit. With ``"current"`` an axis is never
  selected before it has entered its band, so ``e2_k ≠ 0`` whenever it is.
* ``diagnostics.critical`` for ``gpm`` lists the axes currently in the band
  (``e2_i ≠ 0``), which are the only ones the gradient acts on (none when α = 0).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.redundancy.base import RCOND, Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.declare import LawKernel
from redservo.redundancy.flags import Event
from redservo.redundancy.kernel_call import kernel_compute
from redservo.redundancy.kio import (
    F_ALPHA,
    LawOutputs,
    task_context,
)
from redservo.redundancy.law_diagnostics import kernel_diagnostics
from redservo.redundancy.linalg import TaskSVD
from redservo.redundancy.options import Option, slotted

__all__ = ["ALPHA_FILTER", "GradientProjection", "GradientProjectionAuto", "null_project"]

_DEN_TOL = 1e-10
"""``|(J1^⊥ e2)_k|`` at or below ``_DEN_TOL * max|e2|`` counts as zero in eq. 9."""
_I_K = 5
_F_ALPHA_RAW, _F_DEN = 3, 4
"""Outputs of :func:`redservo.kernels.laws.gpm_auto` (layout documented there)."""
ALPHA_FILTER = 1e-2
"""Robust eq. 9: ``1/g_k`` is filtered below ``ALPHA_FILTER ‖g‖`` (``g = J1^⊥ e2``), so the
secondary motion ``α g`` is at most ``1/ALPHA_FILTER`` times the motion ``|w_k|`` it stops."""


_NONE: FloatArray = np.zeros(0)
"""An output a law's kernel does not have."""
if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import linalg as _KL
else:
    _KL = lazy("linalg")


def null_project(svd: TaskSVD, v: FloatArray) -> FloatArray:
    """Return ``J1^⊥ v = E (E^T v)`` (n,) without forming the n x n projector."""
    V = np.ascontiguousarray(svd.V)
    return np.asarray(_KL.null_project(V, svd.rank, np.ascontiguousarray(v, dtype=np.float64)))


@register
class GradientProjection(Law):
    """Gradient projection with a fixed gain: ``q̇ = -λ (J1⁺e1 + α J1^⊥ e2)`` (CM01 eqs. 1-6)."""

    name = "gpm"
    description = "gradient projection, q̇ = -λ(J1⁺e1 + α J1^⊥ e2) (CM01 eqs. 1-6)"

    KERNEL = LawKernel(
        "redservo.kernels.laws:gpm",
        "J1 e q lp lam sec has_sec opt.alpha opt.rcond opt.robust",
        "redservo.kernels.events:gpm_events",
        "m n iout opt.robust",
    )
    OPTIONS, SLOTS = slotted(
        (
            Option(
                "alpha",
                2.0,
                doc="gain α of the joint-limit gradient, relative to λ",
                ref="CM01 eq. 6, §V-A2 (the smallest value that succeeded)",
                low=0.0,
                slot_kind="f",
            ),
            RCOND,
        )
    )
    alpha: float

    def compute(self, x: LawInputs) -> LawResult:
        """The raw command and diagnostics: the law kernel of the step kernel
        (:func:`~redservo.redundancy.kernel_call.kernel_compute`)."""
        return LawResult(*kernel_compute(self, x))

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics from the kernel's outputs ``out`` (m task rows; ``more``: events to
        append, the safety layer's): the axes in the band are the critical ones."""
        band = tuple(int(i) for i in np.flatnonzero(out.axes))
        return kernel_diagnostics(
            self, m, out, more, critical=(band,) if band else (), alpha=self.alpha
        )


@register
class GradientProjectionAuto(Law):
    """Gradient projection with α computed to stop the most critical axis (CM01 eqs. 7-9).

    ``α = -w_k / (J1^⊥ e2)_k`` (eq. 9 corrected) with ``w = J1⁺e1 - J1^⊥ secondary/λ``
    and k the critical axis whose prediction ``q̂ = q - λ dt w`` (eq. 8) is closest
    to its limit; see the module docstring for the degenerate cases.
    """

    name = "gpm-auto"
    description = "gradient projection with α chosen to stop the most critical axis (CM01 eq. 9)"

    KERNEL = LawKernel(
        "redservo.kernels.laws:gpm_auto",
        "J1 e q lp lam dt sec has_sec opt.alpha_max opt.critical_rule? opt.rcond opt.robust"
        " opt.auto_robust?",
        "redservo.kernels.events:gpm_auto_events",
        "m n iout axf opt.robust opt.alpha_max",
    )
    OPTIONS, SLOTS = slotted(
        (
            Option(
                "alpha_max",
                None,
                doc="upper bound on α (None or inf: none, CM01 Fig. 10(c)'s transient)",
                ref="CM01 eq. 9",
                low=0.0,
                low_open=True,
                finite=False,
                none=True,
                slot_kind="f",
            ),
            Option(
                "critical_rule",
                "predicted",
                kind="choice",
                doc="candidates: predicted q̂ or current q in the band",
                ref="CM01 eq. 8, §II-C",
                choices=("predicted", "current"),
                slot_kind="i",
            ),
            RCOND,
        ),
        packed=(("auto_robust", "i"),),
    )
    alpha_max: float | None
    critical_rule: str

    def packed_extras(self) -> tuple[tuple[tuple[str, int], float], ...]:
        """Also the robust eq. 9 (:mod:`redservo.kernels.lawopts`)."""
        return (*super().packed_extras(), (self.SLOTS["auto_robust"], int(self.robust)))

    def compute(self, x: LawInputs) -> LawResult:
        """The raw command and diagnostics: the law kernel of the step kernel
        (:func:`~redservo.redundancy.kernel_call.kernel_compute`)."""
        return LawResult(*kernel_compute(self, x))

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics from the kernel's outputs ``out`` (m task rows; ``more``: events to
        append, the safety layer's; ``axf`` holds the candidates): the stopped axis is critical
        when a positive α is applied."""
        iout, fout = out.iout, out.fout
        axis = int(iout[_I_K])
        alpha = float(fout[F_ALPHA])
        return kernel_diagnostics(
            self,
            m,
            out,
            more,
            lambda: self._context(m, iout, fout, out.axf),
            critical=((axis,),) if alpha > 0.0 else (),
            alpha=alpha,
        )

    def _context(
        self, m: int, iout: NDArray[np.int64], fout: FloatArray, cand: FloatArray
    ) -> dict[str, Any]:
        """The numbers the messages of eq. 9 corrected name, ``α = -w_k / g_k`` and its
        degenerate cases (module docstring): the axis k, the other candidates, ``|g_k|``, the
        raw α and the filter's bound. With ``robust`` on, ``1/g_k`` is filtered below
        ``ALPHA_FILTER ‖g‖`` so that ``‖α g‖ <= |w_k| / ALPHA_FILTER``."""
        axis = int(iout[_I_K])
        return {
            **task_context(m, iout, fout, self.filter_threshold),
            "axis": axis,
            "others": lambda: [int(i) for i in np.flatnonzero(cand) if i != axis],
            "den": float(fout[_F_DEN]),
            "alpha_raw": float(fout[_F_ALPHA_RAW]),
            "inv_alpha_filter": 1.0 / ALPHA_FILTER,
        }
