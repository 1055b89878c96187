"""Directional redundancy (Mansard & Chaumette 2005, "MC05", eqs. 9-23).

The classical formalism (MC05 eq. 7) only lets the secondary command act in
``Ker J1``. MC05 asks less: the secondary displacement ``dq2`` must not *increase*
the main-task error after the step (eq. 9),

    ``||e + de + J1 dq2|| <= ||e + de||``,

so it may also use the task directions in which it *helps* the main task.

Per control step of period ``dt`` (with the real period, docs/formulas.md §8):

1. ``de = -λ e_eff dt`` (main-task displacement, feed-forward folded in) and
   ``dq1 = J1^+ de`` (eq. 3).
2. ``z = dt (-κ e2 + secondary)``: the joint-limit force of MC05 eqs. 27-29 (the
   same cost as CM01, ``e2 = JointLimits.gradient(q)``) plus the user's
   ``secondary`` joint-velocity command.
3. In the SVD bases ``J1 = U diag(σ) V^T``: ``ẽ = U^T e``, ``dẽ = U^T de``,
   ``z̃ = V^T z`` (eqs. 11-14) and ``a_i = ẽ_i + dẽ_i``. For ``i < rank`` the
   sufficient componentwise condition (eq. 18) is ``y (y + 2 a_i) <= 0`` with
   ``y = σ_i dq̃2_i``, i.e. ``y`` between 0 and ``-2 a_i``. The projection (eq. 20)
   takes the nearest such ``y`` to ``σ_i z̃_i``, i.e. clamps ``σ_i z̃_i`` to the
   interval between 0 and ``-2 μ a_i`` (``μ = margin``, 1 in the paper):

   * keep ``z̃_i`` if ``σ_i z̃_i`` already lies in it;
   * 0 if ``σ_i z̃_i`` has the same sign as ``a_i`` (it would increase ``|e_i|``);
   * ``-2 μ a_i / σ_i`` otherwise (right direction, overshoot).

   For ``i >= rank`` keep ``z̃_i`` (the classical null space, eq. 24).
4. ``P̃_z = diag(p_i)``, ``p_i = dq̃2_i / z̃_i`` (1 when ``z̃_i = 0``), eq. 21;
   ``P_z = V P̃_z V^T`` (eq. 22); ``dq = dq1 + P_z z`` (eq. 23); ``q̇ = dq / dt``.

**p_i lies in [0, 1].** ``p_i = clamp(y, I) / y`` with ``y = σ_i z̃_i ≠ 0`` and I the
interval between 0 and ``-2 μ a_i``, which contains 0. Clamping into an interval
that contains 0 never changes the sign of y to the opposite one and never
increases ``|y|``: ``clamp(y, I)`` is 0 or has the sign of y, and
``|clamp(y, I)| <= |y|``. Hence ``0 <= p_i <= 1`` (and ``p_i = 1`` for ``i >= rank``
or ``z̃_i = 0``). ``P_z`` is therefore symmetric with eigenvalues ``p_i`` in
[0, 1]; it is *not* a projector (not idempotent), only the matrix form of the
non-linear operator (MC05 §III-C), and its rank is between ``n - rank`` and n.

**The step never increases the error (eq. 9).** For ``i < rank``, ``y`` clamped to
I gives ``|a_i + y| <= |a_i|`` (I is the set where this holds, scaled by μ <= 1
toward 0); ``J1 dq2`` has task components ``σ_i dq̃2_i`` only for ``i < rank`` up to
the sub-threshold singular values (see below). So ``||e1 + J1 q̇ dt||`` is at most
the classical prediction ``||e1 + J1 q̇1 dt||``, which is ``(1 - λ dt) ||e1||``
when ``J1`` has full row rank.

Decisions (docs/formulas.md §8; recorded for docs/decisions.md):

* **Eq. 20 sign.** The extracted eq. 20 zeroes the component when ``σ_i z̃_i`` and
  ``ẽ_i + dẽ_i`` have *opposite* signs; the derivation from eq. 18 requires
  zeroing when they have the *same* sign (that motion increases ``|e_i|``). We
  follow the derivation; the tests check eq. 9, which the printed sign violates.
* **Eq. 22 transpose.** The extracted ``P_z = V P̃_z V`` lost a transpose: we use
  ``V P̃_z V^T``.
* **Feed-forward.** With a moving target (``de1_dt``), the error the step starts
  from is ``e = e1 + dt ∂e1/∂t`` (the target's own motion over the period) and
  ``de = -λ dt e_eff = -λ dt (e1 + ∂e1/∂t / λ)``, so
  ``a = (1 - λ dt) U^T e1``: the bound protects the classical predicted error,
  the quantity eq. 9 compares with.
* **Rank loss.** Singular values below ``rcond·σ_max`` count as zero, exactly as
  in ``J1^⊥`` for the classical law: their right singular directions are free
  (``p_i = 1``). The secondary term may then move the task by at most
  ``rcond·σ_max ||z||`` along them, as the classical projector does. Task
  components outside the range of ``J1`` are not affected by any joint motion.
  Nothing raises; ``rank_deficient`` and a note report it.
* **Gain κ.** MC05 gives no value. Default ``kappa = 1.0`` (joint units per
  second per unit of the dimensionless ``e2``; ``e2`` reaches ``rho`` = 0.1 at a
  real limit, so the force is at most about 0.1 rad/s or m/s at the limit).
* **margin.** ``μ`` in (0, 1] shrinks the admissible interval to
  ``[0, -2 μ a_i]``. ``μ = 1`` (paper) allows a component's error to flip sign
  with unchanged magnitude in one step (oscillation risk when the force is
  large); ``μ = 1/2`` at most zeroes it. Default 1 (paper).
* **λ dt.** The bound is a per-step displacement. If ``λ dt = 1``, ``a = 0`` and
  no task direction is freed; the continuous-time limit (dt → 0) keeps only the
  sign condition.
* **Rank of P_z.** :attr:`DirectionalProjection.rank` counts the non-zero
  ``p_i``, with ``p_i = 1`` for ``z̃_i = 0`` as in eq. 21, so it is n when
  ``z = 0``. The law's ``Diagnostics.projector_rank`` (MC05 Fig. 3, "number of
  DOF left for the avoidance") counts instead the directions the secondary
  command can actually use: the ``n - rank(J1)`` null-space directions plus the
  task directions with ``z̃_i ≠ 0`` and ``p_i > 0``. It is therefore 0 for a
  full-rank task when no force acts, as MC05 §V-A describes ("when the robot is
  near the joint limits, the projection operator is not null"); ``P_z z`` is the
  same under either count.
* ``J1`` with more rows than columns (m > n) works the same way.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError, ShapeError
from redservo.kernels import lazy
from redservo.redundancy.base import RCOND, Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.declare import LawKernel
from redservo.redundancy.flags import Event
from redservo.redundancy.kernel_call import kernel_compute
from redservo.redundancy.kio import (
    I_RANK,
    LawOutputs,
)
from redservo.redundancy.law_diagnostics import kernel_diagnostics
from redservo.redundancy.options import Option, slotted

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import directional as _K
else:
    _K = lazy("directional")
_I_FREED, _I_CLIPPED, _I_BLOCKED, _I_ANY_Z = 5, 6, 7, 8
"""Outputs of :func:`redservo.kernels.directional.directional` (layout documented there)."""
_NONE: FloatArray = np.zeros(0)
"""An output the law's kernel does not have."""

__all__ = ["Directional", "DirectionalProjection", "directional_projection"]


class DirectionalProjection(NamedTuple):
    """The result of MC05's non-linear projection of one secondary displacement."""

    dq2: FloatArray
    """(n,) admissible secondary displacement ``P_z z`` (joint units)."""
    p: FloatArray
    """(n,) diagonal of ``P̃_z`` in the V basis (eq. 21), each in [0, 1]."""
    P: FloatArray
    """(n, n) ``P_z = V P̃_z V^T`` (eq. 22), symmetric, eigenvalues ``p``."""

    @property
    def rank(self) -> int:
        """Rank of ``P_z``: the number of non-zero ``p_i`` (MC05 Fig. 3)."""
        return int(np.count_nonzero(self.p))


def directional_projection(
    U: ArrayLike,
    sigma: ArrayLike,
    V: ArrayLike,
    rank: int,
    e: ArrayLike,
    de: ArrayLike,
    z: ArrayLike,
    *,
    margin: float = 1.0,
) -> DirectionalProjection:
    """Project the secondary displacement ``z`` onto MC05's free space (eqs. 18-22).

    Pure function on the SVD ``J1 = U diag(σ) V^T`` (e.g. from
    :func:`~redservo.redundancy.linalg.task_svd`). All quantities are per-step
    displacements: ``e`` and ``de`` in task units, ``z`` in joint units.

    Args:
        U: (m, k) left singular vectors, ``k >= rank`` (the first ``rank`` are used).
        sigma: (>= rank,) singular values; the first ``rank`` are the non-zero ones.
        V: (n, n) right singular vectors as columns (orthogonal).
        rank: Numerical rank r of ``J1``; directions ``V[:, r:]`` are free.
        e: (m,) task error at the start of the step.
        de: (m,) commanded task displacement over the step (``-λ e dt``).
        z: (n,) secondary displacement to project (joint units).
        margin: μ in (0, 1]; the admissible interval is between 0 and ``-2 μ a_i``.

    Returns:
        :class:`DirectionalProjection` ``(dq2, p, P)`` with ``dq2 = P z``.

    Raises:
        ShapeError: inconsistent shapes or non-finite values.
        ConfigurationError: ``margin`` outside (0, 1].
    """
    mu = _check_margin(margin)
    Ua = _finite(U, "U", 2)
    Va = _finite(V, "V", 2)
    sig = _finite(sigma, "sigma", 1)
    ea = _finite(e, "e", 1)
    dea = _finite(de, "de", 1)
    za = _finite(z, "z", 1)
    m = Ua.shape[0]
    n = Va.shape[0]
    r = int(rank)
    if Va.shape != (n, n):
        raise ShapeError(f"V must be square (n, n), got shape {Va.shape}")
    if not (0 <= r <= min(m, n)) or Ua.shape[1] < r or sig.shape[0] < r:
        raise ShapeError(
            f"rank must satisfy 0 <= rank <= min(m, n) = {min(m, n)} with U having at least "
            f"rank columns and sigma at least rank entries; got rank={rank}, U {Ua.shape}, "
            f"sigma {sig.shape}"
        )
    for name, arr, size in (("e", ea, m), ("de", dea, m), ("z", za, n)):
        if arr.shape != (size,):
            raise ShapeError(f"{name} must have shape ({size},), got shape {arr.shape}")

    c = np.ascontiguousarray
    dq2, p, P = _K.projection(c(Ua), c(sig), c(Va), r, c(ea), c(dea), c(za), mu, True)
    return DirectionalProjection(dq2, p, P)


def _finite(value: ArrayLike, name: str, ndim: int) -> FloatArray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim != ndim:
        raise ShapeError(f"{name} must be a {ndim}-D array, got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ShapeError(f"{name} must be finite (no NaN or inf)")
    return arr


def _check_margin(margin: float) -> float:
    mu = float(margin)
    if not (np.isfinite(mu) and 0.0 < mu <= 1.0):
        raise ConfigurationError(
            f"margin (fraction of MC05's admissible interval) must lie in (0, 1], got {margin!r}"
        )
    return mu


@register
class Directional(Law):
    """Directional redundancy, MC05 eqs. 10-23, with the joint-limit force of eqs. 27-29.

    ``q̇ = -λ J1^+ e_eff + P_z z / dt`` with ``z = dt (-κ e2 + secondary)`` and
    ``P_z`` MC05's non-linear projector (see the module docstring). The secondary
    command may use the task directions in which it helps the main task, so it
    acts even when ``J1`` is square and full rank (MC05 experiment 1), and the
    predicted error is never larger than with the classical law (eq. 9).
    """

    name = "directional"
    description = "MC05 directional redundancy: secondary motion allowed where it helps the task"

    KERNEL = LawKernel(
        "redservo.kernels.directional:directional",
        "J1 e1 e ff has_ff q lp lam dt sec has_sec opt.kappa opt.use_joint_limits? opt.margin"
        " opt.rcond opt.robust",
        "redservo.kernels.events:directional_events",
        "m n iout opt.robust",
    )
    OPTIONS, SLOTS = slotted(
        (
            Option(
                "kappa",
                1.0,
                doc="joint-limit force gain κ",
                ref="MC05 eqs. 27-29",
                low=0.0,
                low_open=True,
                slot_kind="f",
            ),
            Option(
                "use_joint_limits",
                True,
                kind="bool",
                doc="add the joint-limit force -κ e2 (False: only secondary is projected)",
                ref="MC05 eq. 27",
                slot_kind="i",
            ),
            Option(
                "margin",
                1.0,
                doc="μ shrinking the admissible interval [0, -2 a_i] (1: the paper's)",
                ref="MC05 eqs. 10-23",
                low=0.0,
                high=1.0,
                low_open=True,
                slot_kind="f",
            ),
            RCOND,
        ),
    )
    kappa: float
    use_joint_limits: bool
    margin: float

    def compute(self, x: LawInputs) -> LawResult:
        """The raw command and diagnostics: the law kernel of the step kernel
        (:func:`~redservo.redundancy.kernel_call.kernel_compute`)."""
        return LawResult(*kernel_compute(self, x))

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics from the kernel's outputs ``out`` (m task rows; ``more``: events to
        append, the safety layer's): the task directions freed, clipped and blocked are an
        information line."""
        iout = out.iout
        r = int(iout[I_RANK])
        n = out.axes.shape[0]
        info: list[str] = []
        if iout[_I_ANY_Z]:
            info.append(
                f"task directions: {int(iout[_I_FREED])} free, {int(iout[_I_CLIPPED])} clipped, "
                f"{int(iout[_I_BLOCKED])} blocked (of {r}); {n - r} null-space direction(s)"
            )
        return kernel_diagnostics(self, m, out, more, info=tuple(info))
