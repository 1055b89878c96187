"""Large projection operator and joint-limit law of Marey & Chaumette (ICRA'10, IROS'10; docs/formulas.md §10.3).

Norm-based projector (ICRA'10), with ``v = J1^T e1``::

    P_‖e‖ = I_n - v v^T / (v^T v)                      (rank n - 1)

``e1^T J1 P_‖e‖ = 0``: a motion ``P_‖e‖ g`` leaves ``d‖e1‖/dt`` unchanged, and
this keeps n - 1 free directions even when ``J1`` is square and full rank.
Switched projector (ICRA'10 eq. 24), used far from and near convergence::

    P_λ = λ(‖e‖) P_‖e‖ + (1 - λ(‖e‖)) (I - J1⁺ J1)
    λ(‖e‖) = 1 if ‖e‖ > e1;  0 if ‖e‖ < e0;
             1 / (1 + exp(-12 (‖e‖ - e0)/(e1 - e0) + 6)) in between

Primary term ``q̇1 = -λ J1⁺ e_eff`` (as ViSP pairs it with ``P_λ``); with a
full-row-rank ``J1``, ``e1^T J1 q̇ = -λ ‖e1‖²`` whatever the projected terms, so
``‖e1‖`` still decays as ``exp(-λt)``.

Joint-limit law (IROS'10), with ``Δq_i = q_max,i - q_min,i``::

    q_l0 = (q_min + ρ Δq, q_max - ρ Δq),    q_l1 = q_l0 ∓ ρ ρ1 Δq     (l1 between l0 and the limit)
    g_i = +e_i if q_i > q_l0max,i;  -e_i if q_i < q_l0min,i;  0 otherwise
    λ_l,i = 1/(1 + exp(-12 (q_i - q_l0,i)/(q_l1,i - q_l0,i) + 6)) between l0 and l1, 1 beyond l1
    b_i = |q̇1,i| / |(P g_i)_i|,    λ_sec,i = (1 + λ_tune) b_i
    q̇2 = -Σ_i λ_l,i λ_sec,i P g_i,    q̇ = q̇1 + q̇2

Beyond l1, joint i on its own gets ``q̇_i = q̇1,i - (1 + λ_tune)|q̇1,i| sign(g_i)``:
motion toward the limit is reversed. Coupling through P from the other joints'
terms is not bounded.

Decisions (the paper is silent or ambiguous; listed for docs/decisions.md):

* **ViSP variant reproduced: the corrected one** (docs/formulas.md §10.3, ViSP
  version caveat; PRs lagadic/visp#1945 and #1979). ``b_i`` is unbounded beyond
  l1, clamped to at most 1 in the transition zone [l0, l1], and ``b_i := 1``
  when ``|(P g_i)_i| < 10 ε_machine``. The older ViSP behaviour (skipping the
  whole correction when ``b_i >= 1``, i.e. exactly when the task drives hard into
  the limit, issue #1946) is *not* reproduced.
* **Which error.** The projector and ``λ(‖e‖)`` use the measured ``e1`` (not
  ``e_eff``), because ``d‖e1‖²/dt = 2 e1^T (J1 q̇ + ∂e1/∂t)`` is what the
  projected terms must not change. ``q̇1`` uses ``e_eff`` (feed-forward).
* **Thresholds.** ``e0 = 0.1``, ``e1 = 0.7`` are ViSP's hard-coded values, in the
  units of the task error: they must be retuned for other features. The joint
  thresholds come from this law's own ``rho``/``rho1`` (defaults 0.1/0.3 as in
  ViSP), not from ``limits.rho``; ``limits`` only supplies ``q_min``/``q_max``.
* **``q̇1`` fed to the joint-limit law** is the primary term plus the projected
  ``secondary`` (``q̇1 = -λ J1⁺ e_eff + P secondary``; "other secondary terms",
  IROS'10 eq. 21), never a measured velocity.
* **Degenerate norm projector.** When ``‖J1^T e1‖ <= rcond σ_max(J1) ‖e1‖`` (in
  particular ``e1 = 0``, or ``e1`` in the left null space of a rank-deficient
  ``J1``), ``P_‖e‖ := I``: then ``e1^T J1 = 0`` anyway, so the property
  ``e1^T J1 P = 0`` still holds (noted in the diagnostics).
* ``projector="switched"`` (default) uses ``P_λ``; ``"norm"`` always uses
  ``P_‖e‖`` (λ ≡ 1); ``"classical"`` always uses ``I - J1⁺J1`` (λ ≡ 0), the
  comparison case of IROS'10.
* Diagnostics: ``alpha`` holds the switching value ``λ(‖e‖)`` in [0, 1] actually
  used; ``projector_rank`` the rank of P; ``critical = ((activated joints),)``
  (``g_i ≠ 0``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.kernels import lazy
from redservo.limits import JointLimits
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
from redservo.redundancy.linalg import DEFAULT_RCOND, TaskSVD, task_svd
from redservo.redundancy.options import Option, slotted
from redservo.redundancy.packs import limits_pack

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import projection as _K
else:
    _K = lazy("projection")
_I_DEGENERATE = 5
_MODES = {"switched": 0, "norm": 1, "classical": 2}
_NONE: FloatArray = np.zeros(0)
"""An output the law's kernel does not have."""

__all__ = [
    "LargeProjection",
    "Projector",
    "joint_limit_term",
    "norm_projector",
    "sigmoid_gain",
    "switched_projector",
    "switching_value",
]

_PROJECTORS: tuple[str, ...] = ("switched", "norm", "classical")


class Projector(NamedTuple):
    """A projection operator for the secondary terms."""

    P: FloatArray
    """(n, n) symmetric positive semi-definite operator."""
    rank: int
    """Its rank."""
    switching: float
    """λ(‖e‖) in [0, 1] used to build it (1: pure norm projector, 0: ``I - J1⁺J1``)."""
    degenerate: bool
    """True when ``J1^T e1 ≈ 0`` and the norm projector was replaced by the identity."""


P_FILTER = 1e-2
"""Robust variant (``robust=True``): ``1/|P_ii|`` is filtered below this, bounding the
joint-limit term's gain ``b_i`` by ``100 |q̇1_i|``."""


def sigmoid_gain(x: float, x0: float, x1: float) -> float:
    """Return ``1/(1 + exp(-12 (x - x0)/(x1 - x0) + 6))`` (ICRA'10 eq. 24 and IROS'10).

    0.0025 at ``x = x0``, 0.5 halfway, 0.9975 at ``x = x1``. ``x1 < x0`` is allowed
    (the lower joint limit side).
    """
    return float(_K.sigmoid_gain(float(x), float(x0), float(x1)))


def switching_value(e_norm: float, e0: float, e1: float) -> float:
    """Return λ(‖e‖) of ICRA'10 eq. 24: 0 below ``e0``, 1 above ``e1``, sigmoid between."""
    return float(_K.switching_value(float(e_norm), float(e0), float(e1)))


def norm_projector(
    J1: FloatArray, e1: FloatArray, *, rcond: float = DEFAULT_RCOND
) -> tuple[FloatArray, bool]:
    """Return ``(P_‖e‖, degenerate)``: ``I - v v^T/(v^T v)`` with ``v = J1^T e1`` (n x n).

    ``degenerate`` is True (and ``P = I``) when ``‖v‖ <= rcond σ_max(J1) ‖e1‖``.

    Args:
        J1: (m, n) task Jacobian.
        e1: (m,) task error.
        rcond: Relative threshold for ``J1^T e1 ≈ 0``.
    """
    J = np.ascontiguousarray(J1, dtype=np.float64)
    smax = float(task_svd(J).sigma[0]) if J.size else 0.0
    P, degenerate = _K.norm_projector(J, np.ascontiguousarray(e1, float), smax, float(rcond))
    return P, bool(degenerate)


def switched_projector(
    J1: FloatArray,
    e1: FloatArray,
    *,
    e0: float = 0.1,
    e_switch: float = 0.7,
    mode: str = "switched",
    svd: TaskSVD | None = None,
    rcond: float = DEFAULT_RCOND,
) -> Projector:
    """Return ``P_λ = λ(‖e1‖) P_‖e‖ + (1 - λ(‖e1‖)) (I - J1⁺J1)`` (ICRA'10 eq. 24).

    Args:
        J1: (m, n) task Jacobian.
        e1: (m,) task error (task units).
        e0: Lower switching threshold on ``‖e1‖`` (task units).
        e_switch: Upper switching threshold ``e1`` of the paper (task units), > e0.
        mode: ``"switched"``, ``"norm"`` (λ ≡ 1) or ``"classical"`` (λ ≡ 0).
        svd: The SVD of ``J1`` if already computed.
        rcond: Relative singular-value cut-off.
    """
    if mode not in _PROJECTORS:
        raise ConfigurationError(
            f"projector mode must be one of {', '.join(repr(p) for p in _PROJECTORS)}, got {mode!r}"
        )
    J = np.ascontiguousarray(J1, dtype=np.float64)
    sv = task_svd(J, rcond) if svd is None else svd
    smax = float(sv.sigma[0]) if sv.sigma.size else 0.0
    P, rank, lam, degenerate = _K.switched_projector(
        J,
        np.ascontiguousarray(e1, dtype=np.float64),
        float(e0),
        float(e_switch),
        _MODES[mode],
        np.ascontiguousarray(sv.V),
        sv.rank,
        smax,
        float(rcond),
    )
    return Projector(P, int(rank), float(lam), bool(degenerate))


def joint_limit_term(
    q: FloatArray,
    qdot1: FloatArray,
    P: FloatArray,
    limits: JointLimits,
    *,
    rho: float = 0.1,
    rho1: float = 0.3,
    lambda_tune: float = 0.7,
    robust: float = 0.0,
) -> tuple[FloatArray, tuple[int, ...]]:
    """Return ``(q̇2, activated)``: the IROS'10 joint-limit term ``-Σ λ_l,i λ_sec,i P g_i``.

    Corrected ViSP variant (module docstring): ``b_i`` unbounded beyond l1,
    ``<= 1`` between l0 and l1, and 1 when ``|P_ii| < 10 ε_machine``.

    Args:
        q: (n,) joint positions (m or rad).
        qdot1: (n,) primary (plus projected secondary) joint velocity.
        P: (n, n) projector.
        limits: The joint limits (only ``q_min``, ``q_max`` are used).
        rho: Activation band l0 as a fraction of the range, in (0, 0.5).
        rho1: Position of l1 inside the band, fraction of ``rho Δq``, in (0, 1).
        lambda_tune: λ_i >= 0, extra reversal gain.
        robust: Filter threshold on ``|P_ii|`` (0: exact): ``1/|P_ii|`` in ``b_i`` is
            filtered below it, so ``b_i <= |q̇1_i| / robust``.
    """
    c = np.ascontiguousarray
    qdot2, activated = _K.joint_limit_term(
        c(q, dtype=np.float64),
        c(qdot1, dtype=np.float64),
        c(P, dtype=np.float64),
        limits_pack(limits).rows,
        float(rho),
        float(rho1),
        float(lambda_tune),
        float(robust),
    )
    return qdot2, tuple(int(i) for i in np.flatnonzero(activated))


@register
class LargeProjection(Law):
    """Marey & Chaumette 2010: switched large projection operator and joint-limit law.

    ``q̇ = -λ J1⁺ e_eff + P secondary + q̇2`` with ``P = P_λ`` (ICRA'10 eq. 24) and
    ``q̇2`` the IROS'10 joint-limit term (corrected ViSP variant, see the module
    docstring). ``diagnostics.alpha`` holds λ(‖e1‖).
    """

    name = "large-projection"
    description = "large projection operator P_λ and joint-limit law (Marey & Chaumette 2010)"

    KERNEL = LawKernel(
        "redservo.kernels.projection:large_projection",
        "J1 e1 e q lp lam sec has_sec opt.e0 opt.e1 opt.projector opt.rho opt.rho1"
        " opt.lambda_tune opt.rcond opt.robust opt.p_filter",
        "redservo.kernels.events:large_projection_events",
        "m n iout axes opt.robust opt.p_filter",
    )
    OPTIONS, SLOTS = slotted(
        (
            Option(
                "e0",
                0.1,
                doc="lower switching threshold on ‖e1‖ (ViSP's value; retune for your features)",
                unit="task-error units",
                ref="ICRA'10 eq. 24",
                low=0.0,
                slot_kind="f",
            ),
            Option(
                "e1",
                0.7,
                doc="upper switching threshold on ‖e1‖, > e0",
                unit="task-error units",
                ref="ICRA'10 eq. 24",
                low=0.0,
                low_open=True,
                slot_kind="f",
            ),
            Option(
                "rho",
                0.1,
                doc="activation band l0, fraction of each joint range",
                ref="IROS'10 (ViSP's default)",
                low=0.0,
                high=0.5,
                low_open=True,
                high_open=True,
                slot_kind="f",
            ),
            Option(
                "rho1",
                0.3,
                doc="l1 position inside the band, fraction of rho Δq",
                ref="IROS'10 (ViSP's default)",
                low=0.0,
                high=1.0,
                low_open=True,
                high_open=True,
                slot_kind="f",
            ),
            Option(
                "lambda_tune",
                0.7,
                doc="extra reversal gain λ_i",
                ref="IROS'10 (ViSP's default)",
                low=0.0,
                slot_kind="f",
            ),
            Option(
                "projector",
                "switched",
                kind="choice",
                doc="P_λ (switched), P_‖e‖ (norm) or I - J1⁺J1 (classical)",
                ref="ICRA'10 eq. 24, IROS'10",
                choices=_PROJECTORS,
                slot_kind="i",
            ),
            RCOND,
        ),
        packed=(("p_filter", "f"),),
    )
    e0: float
    e1: float
    rho: float
    rho1: float
    lambda_tune: float
    projector: str

    def _setup(self) -> None:
        if not self.e0 < self.e1:
            raise ConfigurationError(
                f"the switching thresholds must satisfy 0 <= e0 < e1 (task-error units), got "
                f"e0={self.e0!r}, e1={self.e1!r}",
                argument="e0",
            )

    def packed_extras(self) -> tuple[tuple[tuple[str, int], float], ...]:
        """Also the robust 1/|P_ii| filter (0: off)."""
        return (
            *super().packed_extras(),
            (self.SLOTS["p_filter"], P_FILTER if self.robust else 0.0),
        )

    def compute(self, x: LawInputs) -> LawResult:
        """The raw command and diagnostics: the law kernel of the step kernel
        (:func:`~redservo.redundancy.kernel_call.kernel_compute`)."""
        return LawResult(*kernel_compute(self, x))

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics from the kernel's outputs ``out`` (m task rows; ``more``: events to
        append, the safety layer's): the axes whose projector entry was activated are critical."""
        iout, fout, axes = out.iout, out.fout, out.axes
        thr, pf = self.filter_threshold, P_FILTER if self.robust else 0.0
        info: list[str] = []
        if iout[_I_DEGENERATE]:
            info.append("J1^T e1 ≈ 0: norm projector replaced by the identity")
        activated = tuple(int(i) for i in np.flatnonzero(axes))

        def context() -> dict[str, Any]:
            n_pf = int(np.count_nonzero(axes == 2))
            ctx = {**task_context(m, iout, fout, thr), "pf": pf, "n_pf": n_pf}
            ctx["inv_pf"] = 1.0 / pf if pf else np.inf
            return ctx

        return kernel_diagnostics(
            self,
            m,
            out,
            more,
            context,
            critical=(activated,) if activated else (),
            alpha=float(fout[F_ALPHA]),
            info=tuple(info),
        )
