"""Weighted least norm (Chan & Dubey, IEEE T-RA 11(2):286-292, 1995; docs/formulas.md §10.1).

::

    q̇ = W⁻¹ J1^T (J1 W⁻¹ J1^T)⁻¹ ẋ,          ẋ = -λ e1 - ∂e1/∂t = -λ e_eff
    H(q) = Σ_i (1/4) Δq_i² / ((q_max,i - q_i)(q_i - q_min,i))
    ∂H/∂q_i = Δq_i² (2 q_i - q_max,i - q_min,i) / (4 (q_max,i - q_i)² (q_i - q_min,i)²)
    w_i = 1 + |∂H/∂q_i|  if joint i moves toward a limit,  else 1

The factor is 1/4 per joint (each term is 1 at mid-range), not Liégeois' 1/n
(docs/formulas.md §10.1). WLN only *slows* motion toward a limit; it does not
guarantee avoidance when the task demands that motion.

Decisions (the paper is silent or ambiguous; listed for docs/decisions.md):

* **Numerically safe solve.** With ``D = W^{-1/2} = diag(1/√w_i)`` the law is
  computed as ``q̇ = D (J1 D)⁺ ẋ`` (one SVD of ``J1 D``), which equals the
  printed formula whenever ``J1 W⁻¹ J1^T`` is invertible and never forms
  ``W`` or inverts the ill-conditioned ``J1 W⁻¹ J1^T``. The weights are handled
  through their inverses ``1/w_i ∈ [0, 1]``: at a limit ``|∂H/∂q_i| = ∞`` and
  ``1/w_i = 0`` exactly (the clamp), so a joint at a limit that the task pushes
  further is *blocked* (``q̇_i = 0``), never NaN. When the blocked joints remove
  task directions (``rank(J1 D) < rank J1``) the task is tracked in the
  (weighted) least-squares sense and a note says so. ``q`` within the
  validation tolerance beyond a limit is treated as at the limit.
* **Direction rule, default ``mode="pinv"`` (stateless).** The paper uses the
  sign of ``Δ|∂H/∂q_i|`` since the previous sample. The default instead
  decides from the command the law would send *without* weighting,
  ``q̇0 = J1⁺ ẋ + J1^⊥ secondary`` (the classical law): joint i moves toward a
  limit when ``sign(∂H/∂q_i) q̇0_i > 0``, the common equivalent of the paper's
  rule (docs/formulas.md §10.1). This keeps the law a pure function.
* **``mode="history"``** reproduces the paper's rule: joint i is penalized when
  ``|∂H/∂q_i(q_k)| - |∂H/∂q_i(q_{k-1})| >= 0``. Such a law instance remembers
  the previous ``|∂H/∂q|`` (it is ``stateful``; call :meth:`~Law.reset` between
  runs). On the first call after a reset, for a joint whose gradient is infinite
  now and before (held at a limit), or when the number of joints changes, the
  stateless rule decides instead, because the history gives no information.
* **``secondary``** is treated as a gradient-like joint-space command in the
  metric W: it is added as ``(I - J_W⁺ J1) W⁻¹ secondary = D (I - (J1D)⁺ J1D) D secondary``
  (the weighted gradient projection), which lies in ``Ker J1`` and is damped on
  the joints the law penalizes. With no penalized joint it is ``J1^⊥ secondary``.
* **Square ``J1``.** For a square, full-rank ``J1`` (m = n) the law reduces to
  ``J1⁻¹ ẋ`` whatever W is (docs/formulas.md §10.1): WLN does nothing then,
  except that a joint exactly at a limit and pushed further is blocked (its
  ``1/w_i = 0``), which makes the task least-squares.
* ``diagnostics.critical`` is ``((penalized joints),)``: the joints with
  ``w_i > 1 + 1e-9`` (moving toward a limit; the tolerance hides the round-off
  of ``∂H/∂q`` at mid-range).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.limits import JointLimits
from redservo.redundancy.base import RCOND, Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.declare import LawKernel
from redservo.redundancy.flags import Event
from redservo.redundancy.kio import (
    LawOutputs,
    kernel_inputs,
    optional,
    task_context,
)
from redservo.redundancy.law_diagnostics import kernel_diagnostics
from redservo.redundancy.options import Option, slotted
from redservo.redundancy.packs import limits_pack

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import directional as _K
    from redservo.kernels import events as _KE
else:
    _K = lazy("directional")
    _KE = lazy("events")
_I_WRANK, _I_WFILTERED, _F_WCOND = 5, 6, 3
"""Outputs of :func:`redservo.kernels.directional.wln` (layout documented there)."""

__all__ = [
    "WeightedLeastNorm",
    "joint_limit_index",
    "joint_limit_index_gradient",
    "wln_inverse_weights",
]

BoolArray = NDArray[np.bool_]
_MODES: tuple[str, ...] = ("pinv", "history")


_REPORT_GRAD = 1e-9
"""Joints with ``w_i > 1 + 1e-9`` are reported as penalized (mid-range round-off is not)."""


def _distances(q: ArrayLike, limits: JointLimits) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Return ``(q_clipped, q_max - q, q - q_min)``, distances >= 0."""
    qc = np.clip(np.asarray(q, dtype=float), limits.q_min, limits.q_max)
    return qc, limits.q_max - qc, qc - limits.q_min


def joint_limit_index(q: ArrayLike, limits: JointLimits) -> float:
    """Return Chan & Dubey's performance criterion ``H(q)`` (dimensionless).

    ``H = Σ_i (1/4) Δq_i² / ((q_max,i - q_i)(q_i - q_min,i))``: each term is 1 at
    mid-range and grows to infinity at a limit (returns ``inf`` there, never NaN).

    Args:
        q: (n,) joint positions (m or rad); values beyond a limit count as at it.
        limits: The joint limits.
    """
    _, d_hi, d_lo = _distances(q, limits)
    with np.errstate(divide="ignore"):
        terms = 0.25 * limits.range**2 / (d_hi * d_lo)
    return float(np.sum(terms))


def joint_limit_index_gradient(q: ArrayLike, limits: JointLimits) -> FloatArray:
    """Return (n,) ``∂H/∂q_i = Δq_i² (2q_i - q_max,i - q_min,i) / (4 (q_max,i - q_i)² (q_i - q_min,i)²)``.

    Units: 1/(m or rad). Zero at mid-range, ``+inf`` at ``q_max`` and ``-inf`` at
    ``q_min`` (never NaN); positive above mid-range.

    Args:
        q: (n,) joint positions; values beyond a limit count as at it.
        limits: The joint limits.
    """
    qa = np.ascontiguousarray(q, dtype=np.float64)
    return np.asarray(_K.wln_gradient(qa, limits_pack(limits).rows))


def wln_inverse_weights(grad: FloatArray, toward: BoolArray) -> FloatArray:
    """Return (n,) ``1/w_i`` in [0, 1]: ``1/(1 + |∂H/∂q_i|)`` where ``toward`` is true, else 1.

    Working with the inverse weights is the clamp of the module docstring: an
    infinite gradient (joint at a limit) gives exactly 0, never NaN.

    Args:
        grad: (n,) ``∂H/∂q`` (may hold ±inf).
        toward: (n,) booleans, joint moving toward a limit.
    """
    t = np.broadcast_to(np.asarray(toward, dtype=bool), np.shape(grad))
    return np.array([_K.inverse_weight(float(g), bool(b)) for g, b in zip(grad, t)])


@register
class WeightedLeastNorm(Law):
    """Weighted least norm: ``q̇ = W⁻¹ J1^T (J1 W⁻¹ J1^T)⁻¹ (-λ e1 - ∂e1/∂t)`` (Chan & Dubey 1995).

    Computed as ``D (J1 D)⁺ ẋ`` with ``D = W^{-1/2}`` (see the module docstring
    for the clamp at a limit, the direction rule and the secondary term).
    """

    name = "wln"
    description = "weighted least norm, w_i = 1 + |∂H/∂q_i| toward a limit (Chan & Dubey 1995)"

    def __new__(cls, *, mode: str = "pinv", **_: Any) -> WeightedLeastNorm:
        # ``stateful`` is a class attribute of Law: a history-mode instance is
        # made of the (unregistered) stateful subclass below.
        target = (
            _WeightedLeastNormHistory if mode == "history" and cls is WeightedLeastNorm else cls
        )
        return super().__new__(target)

    KERNEL = LawKernel(
        "redservo.kernels.directional:wln",
        "J1 e q lp lam sec has_sec opt.mode? hist has_hist opt.rcond opt.robust 1e-9",
        "redservo.kernels.events:wln_events",
        "m n iout opt.robust",
    )
    OPTIONS, SLOTS = slotted(
        (
            Option(
                "mode",
                "pinv",
                kind="choice",
                doc="direction rule: the unweighted command (stateless) or the paper's history",
                ref="Chan & Dubey 1995; docs/formulas.md §10.1",
                choices=_MODES,
                slot_kind="i",
            ),
            RCOND,
        ),
    )
    mode: str

    def _history(self) -> tuple[FloatArray | None, bool]:
        """The previous ``|∂H/∂q|`` for the paper's rule, and whether this mode uses it."""
        return None, False

    def _remember(self, abs_grad: FloatArray) -> None:
        """Keep ``|∂H/∂q|`` for the next call (``mode="history"``)."""

    def compute(self, x: LawInputs) -> LawResult:
        m, n = x.J1.shape
        k = kernel_inputs(x)
        prev, history = self._history()
        prev_arr, has_prev = optional(prev if prev is not None and prev.shape == (n,) else None, n)
        qdot, iout, fout, penalized, abs_grad, blocked = _K.wln(
            k.J1,
            k.e,
            k.q,
            k.lp,
            x.lam,
            k.sec,
            k.has_sec,
            history,
            prev_arr,
            has_prev,
            self.rcond,
            self.filter_threshold,
            _REPORT_GRAD,
        )
        self._remember(abs_grad)
        mask, vals, src = _KE.wln_events(m, n, iout, self.filter_threshold)
        out = LawOutputs(iout, fout, penalized, abs_grad, blocked, mask, vals, src)
        return LawResult(qdot, self.diagnose(m, out))

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics from the kernel's outputs ``out`` (m task rows; ``more``: events to
        append, the safety layer's): its own call's (:meth:`compute`) and the compiled
        step's (the Controller's engine, a call through the step kernel) alike. ``axes``
        holds the penalized joints, ``vec`` those blocked at a limit; ``iout[I_PROJ]`` is 0
        without a secondary command."""
        iout, fout, blocked = out.iout, out.fout, out.vec

        def context() -> dict[str, Any]:
            return {
                **task_context(m, iout, fout, self.filter_threshold),
                "wrank": int(iout[_I_WRANK]),
                "wfiltered": int(iout[_I_WFILTERED]),
                "wcond": float(fout[_F_WCOND]),
                "blocked": lambda: np.flatnonzero(blocked).tolist(),
            }

        axes = tuple(int(i) for i in np.flatnonzero(out.axes))
        return kernel_diagnostics(self, m, out, more, context, critical=(axes,) if axes else ())


class _WeightedLeastNormHistory(WeightedLeastNorm):
    """``wln`` with ``mode="history"``: remembers ``|∂H/∂q|`` of the previous call."""

    stateful = True

    _prev_abs_grad: FloatArray | None = None

    def _setup(self) -> None:
        self._prev_abs_grad = None

    def reset(self) -> None:
        """Forget the previous ``|∂H/∂q|`` (call between runs)."""
        self._prev_abs_grad = None

    def _history(self) -> tuple[FloatArray | None, bool]:
        return self._prev_abs_grad, True

    def _remember(self, abs_grad: FloatArray) -> None:
        self._prev_abs_grad = abs_grad
