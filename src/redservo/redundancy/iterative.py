"""CM01's iterative null-space scheme (§III, eqs. 10-21): four variants, one solver.

The command is (eqs. 10, 12, 14, 20; eqs. 19-21 corrected per docs/formulas.md §14
items 2-3)::

    q̇ = -λ (J1⁺e1 + E a + α J1^⊥ e2) + J1^⊥ secondary

with E (n x n_a) an **orthonormal** basis of ``Ker J1`` (the last ``n - r`` right
singular vectors, r the numerical rank; docs/formulas.md §7.1) and ``a`` built level by
level so that every *constrained* axis k gets ``q̇_k = (1 - γ_k) q̇_k^prev``,
where ``q̇^prev`` is the command of the previous level (``γ_k = 1``: stopped).
``J1 q̇ = -λ e1 - ∂e1/∂t`` is never changed (``J1 E = 0``).

=======================  ======  ======================  ===========================
name                     levels  weights γ_k             α J1^⊥ e2 term
=======================  ======  ======================  ===========================
``iterative-basic``      1       1 (stop)                no   (eqs. 10-12)
``iterative``            all     1 (stop)                no   (eqs. 13-15)
``iterative-smooth``     all     eq. 17 at q̂             no   (eqs. 16-18)
``iterative-smooth-e2``  all     eq. 17 at q̂             yes  (eqs. 19-21)
=======================  ======  ======================  ===========================

Algorithm (:func:`iterate_null_space`). Write ``w`` for the motion to constrain,
``w = J1⁺e1 - J1^⊥ secondary / λ`` (``e1`` is the effective error
``e1 + ∂e1/∂t / λ``), and ``d = E a`` for the null-space motion found so far
(``d = 0`` at level 1). At each level:

1. ``v = w + d`` (``+ α J1^⊥ e2`` from level 2 on, see below) is the current
   control divided by -λ; predict ``q̂ = q - λ dt v`` (eq. 8, and eq. 12 or 20
   at later levels, docs/formulas.md §7.2).
2. ``K`` = axes not constrained yet that are critical at ``q̂`` (rule below). None:
   stop.
3. Solve, in the directions still free, ``Δ_K = -γ_K v_K`` for the minimum-norm
   joint motion ``Δ`` (eq. 11/16 at level 1, eq. 15/18/21 later), ``d += Δ``.

The free directions are kept as an orthonormal basis N (n x f) of
``Ker J1 ∩ {δ : δ_C = 0}``, C the constrained axes, starting from ``N = E``; one
SVD of the small block ``N_K`` (p x f) per level gives both its pseudo-inverse and
the basis of its kernel Z, and ``N <- N Z``. This is CM01's ``a0 = F⁺s`` and
``a = a0 + F^⊥ b`` with all constrained rows stacked (docs/formulas.md §7.4): the joint
motions reachable by ``E F^⊥ b`` are exactly those reachable by ``N c``, and with
both E and N orthonormal the minimum-norm b and c give the same (minimum-norm)
joint motion. It avoids forming ``F^⊥ = I - F⁺F`` and a second pseudo-inverse
per level.

Decisions (the paper is ambiguous or silent; listed for docs/decisions.md):

* **Critical axis** (docs/formulas.md §7.2, :meth:`~redservo.JointLimits.critical`):
  k is critical when ``q̂_k`` lies in the band ``[q̄_min, q̃_min] ∪ [q̃_max, q̄_max]``
  (or beyond the real limit) *and* moves toward that limit (``q̂_k > q_k`` in the
  upper band, ``q̂_k < q_k`` in the lower one; an overshoot past the limit still
  counts). The same rule is used at every level and in every variant.
* **Basic variant and axes already in the band**: CM01 §V-A3 says "any axis that
  is or enters in the critical area is stopped", the critical area being the band
  *and* moving toward the limit (§III-A). So an axis inside the band is stopped
  only if the eq. 8 prediction moves it toward its limit; one moving away is left
  free (stopping it would spend redundancy for nothing), and an axis still outside
  the band is stopped as soon as ``q̂_k`` enters it. Axes pushed into the band by
  the ``E a0`` motion itself are *not* handled (one level only): that is why
  ``q̃_5`` is crossed in CM01 Fig. 11, and what ``iterative`` adds.
* **γ_k** (eq. 17 corrected, :meth:`~redservo.JointLimits.gamma`) is computed from
  the prediction of the level at which axis k is constrained (eq. 18: level 2
  uses the prediction with ``a0``). ``diagnostics.gamma`` holds it (1 in the
  non-smooth variants, 0 on unconstrained axes).
* **e2 variant**: the level-1 system is unchanged (eq. 16): level-1 prediction and
  right-hand side use ``w`` without the α term, so that the e2 term still pushes
  the critical axes away (Fig. 6). From level 2 on, ``v`` includes
  ``α J1^⊥ e2`` (eqs. 20-21 corrected). ``e2`` is eq. 6 at the current q.
  Default ``alpha = 2.0``, as for ``gpm``.
* **secondary** is included in ``w`` (prediction and right-hand sides), so a stopped
  axis stays stopped when a secondary command is added.
* **Levels**: ``max_levels=None`` (default) iterates until no new axis becomes
  critical (at most n levels, since each adds an axis).
* **Rank and conditioning**: the rows of an orthonormal N have singular values in
  [0, 1], so ``σ <= rcond`` is an *absolute* cut-off there. A constraint that the
  free directions cannot meet (more constrained axes than ``n_a``, or rows of E
  that are numerically dependent or zero) is solved in the least-squares sense,
  and ``overconstrained`` is set; levels still continue, so later axes are
  reported even when they cannot be constrained. ``overconstrained`` is also set
  whenever more axes are constrained than ``n_a``.
* **Ill-conditioned constraints.** Stopping an axis that the free directions
  barely move needs a large null-space motion (amplification ``1/σ_min`` of the
  constraint rows): CM01's scheme has no safeguard, and the default cut-off keeps
  it exact. When ``σ_min < 1e-3`` (amplification above 1000) the diagnostics say
  so in a note, with the value. The option ``constraint_rcond`` (absolute, in
  [0, 1)) raises the cut-off: rows below it count as unmeetable (least squares,
  ``overconstrained``) instead of being met with a huge velocity. Found by the
  humanoid tracking campaign (``docs/results.md``).
* **No redundancy** (``rank J1 = n``, e.g. m >= n): E is empty and the law is the
  classical one, with a note; critical axes are still reported (and
  ``overconstrained`` set, as they cannot be slowed).
* ``diagnostics.a = E^T d`` (n_a,) and ``diagnostics.b`` is the concatenation of
  the increments of ``a`` at levels 2, 3, ... (n_a each; ``F^⊥ b`` in CM01's
  notation, equal to b for the minimum-norm solution).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.limits import JointLimits
from redservo.redundancy.base import RCOND, Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.declare import LawKernel
from redservo.redundancy.flags import Event
from redservo.redundancy.kernel_call import kernel_compute
from redservo.redundancy.kio import (
    I_ITER,
    I_OVER,
    LawOutputs,
    levels,
    optional,
    task_context,
)
from redservo.redundancy.law_diagnostics import kernel_diagnostics
from redservo.redundancy.linalg import DEFAULT_RCOND
from redservo.redundancy.options import Option, slotted
from redservo.redundancy.packs import limits_pack

__all__ = [
    "Iterative",
    "IterativeBasic",
    "IterativeSmooth",
    "IterativeSmoothE2",
    "IterativeSolution",
    "iterate_null_space",
]

CONSTRAINT_FILTER = 1e-2
"""Absolute filter threshold of the robust constraint inverse (``robust=True``): each
level's null-space motion is at most 100x its right-hand side."""

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import events as _KE
    from redservo.kernels import iterative as _K
else:
    _K = lazy("iterative")
    _KE = lazy("events")
_I_NCON, _I_NA, _F_MIN_SIGMA = 5, 6, 3
"""Outputs of :func:`redservo.kernels.iterative.iterative` (layout documented there)."""


class IterativeSolution(NamedTuple):
    """Result of :func:`iterate_null_space`."""

    motion: FloatArray
    """(n,) null-space motion ``d = E a`` (same units as ``w``: q̇ = -λ (w + d))."""
    levels: tuple[tuple[int, ...], ...]
    """Axes constrained at each level, level 1 first."""
    steps: tuple[FloatArray, ...]
    """(n,) motion increment of each level, ``Σ steps = motion``."""
    gamma: FloatArray
    """(n,) weight γ_k of each constrained axis (0 elsewhere)."""
    unmet: tuple[int, ...]
    """Levels (1-based) whose constraints were met only in the least-squares sense."""
    min_sigma: float = float("inf")
    """Smallest singular value of the constraint rows used (inf if none): the
    null-space motion is amplified up to ``1/min_sigma``."""


def iterate_null_space(
    E: FloatArray,
    w: FloatArray,
    q: FloatArray,
    limits: JointLimits,
    *,
    lam_dt: float,
    smooth: bool,
    extra: FloatArray | None = None,
    max_levels: int | None = None,
    tol: float = DEFAULT_RCOND,
    robust: float = 0.0,
) -> IterativeSolution:
    """Run CM01's iterative scheme (eqs. 11-18, 21) and return the null-space motion.

    The command is ``q̇ = -λ (w + extra + motion)``; see the module docstring.

    Args:
        E: (n, n_a) orthonormal basis of ``Ker J1``.
        w: (n,) motion to constrain, ``J1⁺e1 - J1^⊥ secondary / λ``.
        q: (n,) current joint positions.
        limits: Joint limits and thresholds.
        lam_dt: ``λ dt`` (dimensionless), for the predictions ``q̂ = q - λ dt v``.
        smooth: Weight the right-hand sides by γ_k (eq. 17); otherwise γ_k = 1.
        extra: (n,) term in ``Ker J1`` left out of the level-1 system and included
            from level 2 on (``α J1^⊥ e2``, eqs. 19-21), or None.
        max_levels: Maximum number of levels, None for no limit.
        tol: Absolute singular-value cut-off for the (orthonormal) constraint rows.
        robust: Absolute filter threshold of the robust constraint inverse (0: exact).
    """
    n = q.shape[0]
    ex, has_extra = optional(extra, n)
    d, level_of, count, steps, gamma, unmet, min_sigma = _K.iterate_null_space(
        np.ascontiguousarray(E, dtype=np.float64),
        np.ascontiguousarray(w, dtype=np.float64),
        np.ascontiguousarray(q, dtype=np.float64),
        limits_pack(limits).rows,
        float(lam_dt),
        bool(smooth),
        ex,
        has_extra,
        -1 if max_levels is None else int(max_levels),
        float(tol),
        float(robust),
    )
    return IterativeSolution(
        d,
        levels(level_of, int(count)),
        tuple(steps[:count]),
        gamma,
        tuple(lv for lv in range(1, int(count) + 1) if unmet[lv]),
        float(min_sigma),
    )


_CON_RCOND = Option(
    "constraint_rcond",
    None,
    doc="absolute cut-off of the constraint rows (None: rcond, exact; e.g. 1e-2 caps the "
    "null-space amplification near ill-conditioned constraints)",
    ref="CM01 eqs. 10-21 (module docstring)",
    low=0.0,
    high=1.0,
    high_open=True,
    none=True,
)
_MAX_LEVELS = Option(
    "max_levels",
    None,
    kind="int",
    doc="maximum number of levels (None: until no new axis becomes critical)",
    ref="CM01 eqs. 13-15",
    low=1,
    none=True,
    slot_kind="i",
)
_ALPHA = Option(
    "alpha",
    2.0,
    doc="gain α of the joint-limit gradient e2, as gpm",
    ref="CM01 eqs. 19-21",
    low=0.0,
    slot_kind="f",
)
_PACKED = (("smooth", "i"), ("con_rcond", "f"), ("con_filter", "f"))
"""What every variant packs besides its options (:meth:`_IterativeLaw.packed_extras`)."""


def _kernel(alpha: str) -> LawKernel:
    """The iterative kernel with ``alpha`` the gain of e2 (``"0.0"``: no e2 term)."""
    return LawKernel(
        "redservo.kernels.iterative:iterative",
        f"J1 e q lp lam dt sec has_sec opt.smooth? {alpha} opt.max_levels opt.rcond"
        " opt.robust opt.con_rcond opt.con_filter",
        "redservo.kernels.events:iterative_events",
        "m n iout fout vec opt.robust opt.con_filter",
    )


class _IterativeLaw(Law):
    """Shared implementation; subclasses choose the variant and expose their options."""

    smooth: ClassVar[bool] = False
    with_e2: ClassVar[bool] = False
    max_levels: int | None = None
    alpha: float = 0.0
    constraint_rcond: float | None = None
    SLOTS: ClassVar[dict[str, tuple[str, int]]]

    def packed_extras(self) -> tuple[tuple[tuple[str, int], float], ...]:
        """Also: smooth γ weights, the levels of a variant without ``max_levels``, the
        constraint rows' cut-off (``rcond`` when None) and robust filter."""
        cr = self.rcond if self.constraint_rcond is None else self.constraint_rcond
        slot = self.SLOTS
        extras: tuple[tuple[tuple[str, int], float], ...] = (
            (slot["smooth"], int(self.smooth)),
            (slot["con_rcond"], cr),
            (slot["con_filter"], CONSTRAINT_FILTER if self.robust else 0.0),
        )
        if not any(o.name == "max_levels" for o in self.OPTIONS):
            levels = -1 if self.max_levels is None else self.max_levels
            extras = (*extras, (slot["max_levels"], levels))
        return (*super().packed_extras(), *extras)

    def compute(self, x: LawInputs) -> LawResult:
        """The raw command and diagnostics: the law kernel of the step kernel
        (:func:`~redservo.redundancy.kernel_call.kernel_compute`)."""
        return LawResult(*kernel_compute(self, x))

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics from the kernel's outputs ``out`` (m task rows; ``more``: events to
        append, the safety layer's; ``axf`` holds γ, ``vec`` the gains a then b)."""
        iout, vec = out.iout, out.vec
        count = int(iout[I_ITER])
        n_a = int(iout[_I_NA])
        nb = max(count - 1, 0) * n_a
        con = CONSTRAINT_FILTER if self.robust else 0.0
        return kernel_diagnostics(
            self,
            m,
            out,
            more,
            lambda: _context(m, iout, out.fout, vec, self.filter_threshold, con),
            critical=levels(out.axes, count),
            iterations=count,
            overconstrained=bool(iout[I_OVER]),
            alpha=self.alpha if self.with_e2 else None,
            a=vec[:n_a],
            b=vec[n_a : n_a + nb],
            gamma=out.axf,
        )


def _context(
    m: int, iout: NDArray[np.int64], fout: FloatArray, vec: FloatArray, thr: float, con: float
) -> dict[str, Any]:
    """The numbers the iterative messages name: the task inverse's, the levels met only in
    the least-squares sense (from 1), the constraint counts, σ_min and the filter ``con``."""
    n_a = int(iout[_I_NA])
    return {
        **task_context(m, iout, fout, thr),
        "unmet": lambda: tuple(int(lv) + 1 for lv in np.flatnonzero(_KE.unmet_levels(iout, vec))),
        "n_con": int(iout[_I_NCON]),
        "n_a": n_a,
        "min_sigma": float(fout[_F_MIN_SIGMA]),
        "con_filter": con,
        "inv_con_filter": 1.0 / con if con else np.inf,
    }


@register
class IterativeBasic(_IterativeLaw):
    """Stop the critical axes in the null space of the task, one level (CM01 eqs. 10-12).

    ``a0 = F⁺ s`` with ``F = E_K``, ``s = -(J1⁺e1)_K`` over the axes K critical
    at the eq. 8 prediction; ``q̇ = -λ (J1⁺e1 + E a0)``.
    """

    name = "iterative-basic"
    description = "stop critical axes in Ker J1, one level (CM01 eqs. 10-12)"
    max_levels = 1
    KERNEL = _kernel("0.0")
    OPTIONS, SLOTS = slotted((RCOND, _CON_RCOND), (*_PACKED, ("max_levels", "i")))


@register
class Iterative(_IterativeLaw):
    """Stop the critical axes level after level in what remains of ``Ker J1`` (CM01 eqs. 13-15)."""

    name = "iterative"
    description = "stop critical axes in Ker J1, iterated (CM01 eqs. 13-15)"

    KERNEL = _kernel("0.0")
    OPTIONS, SLOTS = slotted((_MAX_LEVELS, RCOND, _CON_RCOND), _PACKED)


@register
class IterativeSmooth(Iterative):
    """The iterative scheme with right-hand sides weighted by γ_k (CM01 eqs. 16-18, eq. 17 corrected)."""

    name = "iterative-smooth"
    description = "iterative scheme, smooth γ-weighted slow-down (CM01 eqs. 16-18)"
    smooth = True
    KERNEL = _kernel("0.0")


@register
class IterativeSmoothE2(_IterativeLaw):
    """The smooth iterative scheme plus ``α J1^⊥ e2`` to move away from the limits (CM01 eqs. 19-21).

    Eqs. 19-21 corrected (docs/formulas.md §7.6); the level-1 system is
    that of eq. 16, unchanged.
    """

    name = "iterative-smooth-e2"
    description = "smooth iterative scheme + α J1^⊥ e2 moving away from limits (CM01 eqs. 19-21)"
    smooth = True
    with_e2 = True

    KERNEL = _kernel("opt.alpha")
    OPTIONS, SLOTS = slotted((_ALPHA, _MAX_LEVELS, RCOND, _CON_RCOND), _PACKED)
