"""Saturation in the Null Space (Flacco, De Luca & Khatib, ICRA 2012; docs/formulas.md §10.4).

Velocity bounds for one control period ``T = dt`` (docs/formulas.md §10.4)::

    q̇_min,i = margin · max{ (q_min,i - q_i)/T, -v_max,i, -√(2 a_max,i (q_i - q_min,i)) }
    q̇_max,i = margin · min{ (q_max,i - q_i)/T,  v_max,i,  √(2 a_max,i (q_max,i - q_i)) }

so that ``q + q̇ T`` stays within the limits. Algorithm 1 (single task
``ẋ = -λ e_eff``) then saturates, one at a time, the joints that violate their
bounds (``W_jj = 0``, ``q̇_N,j`` := the bound) and redistributes the task on the
others; when the remaining joints can no longer execute the task
(``rank(J1 W) < rank J1``) it restores the configuration with the largest task
scale ``s* ∈ [0, 1]`` seen so far, ``q̇ = q̇_N + (J1 W)⁺ (s* ẋ - J1 q̇_N)``.
The task direction is kept and only its magnitude is scaled:
``J1 q̇ = s ẋ`` whenever ``J1`` has full row rank.

Decisions (the paper is silent or ambiguous; listed for docs/decisions.md):

* **Masking fix** (docs/formulas.md §10.4): the task-scaling step only considers the
  joints not yet saturated (``W_ii = 1``). A literal transcription re-selects a
  saturated joint (its ``a_i`` is only numerically 0), loops and returns
  infeasible velocities. The loop is capped at ``n + 1`` iterations.
* The joint to saturate is ``j = argmin_i S_max,i`` over the free joints, as in
  the paper. Its velocity is fixed at the bound it currently violates; a joint
  that does not violate a bound at ``s = 1`` is fixed at the bound it reaches as
  ``s`` grows (``q̇_max`` if ``a_j > 0``, else ``q̇_min``).
* ``rank(J1 W) < m`` in the paper becomes ``rank(J1 W) < rank J1`` so that a
  rank-deficient ``J1`` does not trigger the restore at the first iteration.
* **Acceleration limits**: ``a_max`` enters only through the stateless braking
  bound ``±√(2 a_max d)`` above (the joint can still stop before its limit).
  The rate limit ``|q̇ - q̇_prev| <= a_max T`` of the acceleration-level SNS
  (T-RO 2015) needs the previous command and is **not** implemented, so the law
  stays stateless.
* ``margin`` is Flacco's factor in (0, 1] on both bounds (default 1: none).
  ``v_max`` and ``a_max`` are scalars or per-joint (n,) arrays, rad/s (m/s) and
  rad/s² (m/s²).
* **Inconsistent bounds** (``q̇_min,i > q̇_max,i``) can only happen when ``q`` lies
  beyond a limit (within the validation tolerance) by more than the velocity or
  braking limit can recover in one period, i.e. for absurdly small ``v_max`` or
  ``a_max``; this raises :class:`~redservo.errors.InfeasibleError`.
* **``secondary``** is the lowest-priority preferred joint velocity: it is the
  initial ``q̇_N`` of Algorithm 1, so with no saturation
  ``q̇ = J1⁺ ẋ + J1^⊥ secondary`` (the classical law), and saturated joints
  override it. It is not scaled; when no scale in (0, 1] is feasible the
  fallback is ``q̇ = 0`` (secondary dropped), which lies within the bounds.
* A final clip to ``[q̇_min, q̇_max]`` removes round-off (``~1e-15``); a note is
  added if it moved a component by more than the violation tolerance.
* **Safety** (docs/safety.md): the bounds are intersected with the shield's box
  (velocity and acceleration limits of ``limits``, position limits less their margin),
  so that ``sns`` satisfies them without the shield; the result is moved by whole
  float64 steps so that ``q + dt q̇`` is within the limits exactly.
* **Distance rows** (collision avoidance on): the velocity dampers ``J_k q̇ ≥ b_k``
  (:mod:`redservo.redundancy.distance_rows`) are saturated as joints are, in the null space
  of the saturated constraints (:mod:`redservo.redundancy.sns_rows` states how).
* Diagnostics: ``scale`` = the task scale ``s`` (1 when the task is executed in
  full), ``critical = ((saturated joints),)``, ``iterations`` = passes of the
  loop, ``overconstrained = scale < 1``, ``projector_rank`` = dimension of the
  null space left on the free joints, ``free joints - rank(J1 W)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from redservo._validation import FloatArray, _to_float
from redservo.errors import ConfigurationError, InfeasibleError, ShapeError
from redservo.kernels import lazy
from redservo.limits import JointLimits
from redservo.redundancy.base import RCOND, Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.declare import LawKernel
from redservo.redundancy.distance_rows import distance_rows, rows_hold
from redservo.redundancy.inputs import validate_inputs
from redservo.redundancy.kio import kernel_inputs, optional
from redservo.redundancy.linalg import DEFAULT_RCOND
from redservo.redundancy.messages import events
from redservo.redundancy.options import Option, slotted
from redservo.redundancy.packs import limits_pack
from redservo.redundancy.sns_rows import with_rows

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import events as _KE
    from redservo.kernels import sns as _K
else:
    _K = lazy("sns")
    _KE = lazy("events")

__all__ = [
    "SNSSolution",
    "SaturationInNullSpace",
    "sns_solve",
    "sns_velocity_bounds",
    "validate_positive_option",
]

_VIOLATION_RTOL = 1e-10
"""A component counts as violating a bound when it exceeds it by more than ``1e-10 (1 + |bound|)``."""


def validate_positive_option(
    value: float | ArrayLike | None, name: str, unit: str
) -> FloatArray | None:
    """Return a positive scalar or 1-D option as a float array (0-d or 1-d), or None.

    Raises:
        ConfigurationError: not a finite positive scalar or 1-D array of them.
    """
    if value is None:
        return None
    message = (
        f"{name} must be None, a finite number > 0 ({unit}) or a 1-D array of them, one per "
        f"joint; got {value!r}"
    )
    try:
        arr = _to_float(value, name)  # numbers only: "2.0" is refused, not parsed
    except ShapeError:
        raise ConfigurationError(message, argument=name) from None
    if arr.ndim > 1 or arr.size == 0 or not np.all(np.isfinite(arr)) or not np.all(arr > 0.0):
        raise ConfigurationError(message, argument=name)
    return arr


def _per_joint(arr: FloatArray, n: int, name: str) -> FloatArray:
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ConfigurationError(
            f"{name} has {arr.shape[0]} entries but the robot has {n} joints; give a scalar or "
            f"one value per joint"
        )
    return arr


def sns_velocity_bounds(
    q: FloatArray,
    limits: JointLimits,
    dt: float,
    *,
    v_max: FloatArray | None = None,
    a_max: FloatArray | None = None,
    margin: float = 1.0,
) -> tuple[FloatArray, FloatArray]:
    """Return the (n,) joint-velocity bounds ``(q̇_min, q̇_max)`` of SNS (docs/formulas.md §10.4).

    Args:
        q: (n,) joint positions (m or rad).
        limits: The joint limits.
        dt: Control period T (s).
        v_max: Velocity limits, scalar or (n,) (rad/s or m/s), or None.
        a_max: Acceleration limits for the braking bound, scalar or (n,)
            (rad/s² or m/s²), or None.
        margin: Factor in (0, 1] applied to both bounds.

    Raises:
        ConfigurationError: ``v_max`` or ``a_max`` has the wrong length.
        InfeasibleError: some lower bound exceeds its upper bound (see the module docstring).
    """
    n = q.shape[0]
    qa = np.ascontiguousarray(q, dtype=np.float64)
    v, has_v = optional(None if v_max is None else _per_joint(v_max, n, "v_max"), n)
    a, has_a = optional(None if a_max is None else _per_joint(a_max, n, "a_max"), n)
    lo, hi, bad = _K.sns_velocity_bounds(
        qa, limits_pack(limits).rows, float(dt), v, has_v, a, has_a, float(margin)
    )
    if bad >= 0:
        _infeasible(int(bad), lo, hi, qa, limits, dt)
    return lo, hi


def _infeasible(
    i: int, lo: FloatArray, hi: FloatArray, q: FloatArray, limits: JointLimits, dt: float
) -> None:
    """Raise the InfeasibleError of inconsistent SNS bounds on joint ``i``."""
    raise InfeasibleError(
        f"SNS velocity bounds are inconsistent for joint {i}: lower {lo[i]:.6g} > upper "
        f"{hi[i]:.6g} (q[{i}] = {q[i]:.9g} lies outside [{limits.q_min[i]:.9g}, "
        f"{limits.q_max[i]:.9g}] by more than v_max/a_max allow to recover in dt = {dt:.6g} s); "
        f"increase v_max or a_max"
    )


class SNSSolution(NamedTuple):
    """Result of :func:`sns_solve`."""

    qdot: FloatArray
    """(n,) joint velocities within the bounds."""
    scale: float
    """Task scale factor s in [0, 1]."""
    saturated: tuple[int, ...]
    """Joints fixed at a bound (``W_jj = 0``), sorted."""
    iterations: int
    """Passes of the loop of Algorithm 1."""
    free_null_dim: int
    """Null-space dimension left on the free joints, ``#free - rank(J W)``."""
    restored: bool
    """True when the loop ended by restoring the best scale ``s*`` (rank loss or cap)."""
    clipped: float
    """Largest change made by the final clip to the bounds (round-off)."""


def _violation_tol(lo: FloatArray, hi: FloatArray) -> FloatArray:
    return np.asarray(_K.violation_tol(np.ascontiguousarray(lo), np.ascontiguousarray(hi)))


def _task_scaling(
    a: FloatArray,
    b: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    free: NDArray[np.bool_],
    tol: FloatArray,
) -> tuple[float, int]:
    """``getTaskScalingFactor`` of Algorithm 1, over the free joints only (masking fix).

    ``q̇(s) = a s + b``. Returns ``(s_f, j)``: the largest feasible scale (0 if none
    in [0, 1]) and the free joint whose bound limits it (-1 if no free joint).
    """
    c = np.ascontiguousarray
    s, j = _K.task_scaling(
        c(a, float), c(b, float), c(lo, float), c(hi, float), c(free, bool), c(tol, float)
    )
    return float(s), int(j)


def sns_solve(
    J: FloatArray,
    xdot: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    *,
    qdot_pref: FloatArray | None = None,
    rcond: float = DEFAULT_RCOND,
) -> SNSSolution:
    """Algorithm 1 of Flacco et al. 2012 with the masking fix (see the module docstring).

    Args:
        J: (m, n) task Jacobian.
        xdot: (m,) desired task velocity.
        lo: (n,) lower joint-velocity bounds, ``lo <= hi``.
        hi: (n,) upper joint-velocity bounds.
        qdot_pref: (n,) lowest-priority preferred joint velocity (the initial ``q̇_N``), or None.
        rcond: Relative singular-value cut-off of the pseudo-inverses.
    """
    n = J.shape[1]
    c = np.ascontiguousarray
    pref, has_pref = optional(qdot_pref, n)
    qdot, s, saturated, iterations, free_null, restored, clipped, _ = _K.sns_solve(
        c(J, float), c(xdot, float), c(lo, float), c(hi, float), pref, has_pref, float(rcond)
    )
    return SNSSolution(
        qdot=qdot,
        scale=float(s),
        saturated=tuple(int(i) for i in np.flatnonzero(saturated)),
        iterations=int(iterations),
        free_null_dim=int(free_null),
        restored=bool(restored),
        clipped=float(clipped),
    )


@register
class SaturationInNullSpace(Law):
    """Saturation in the Null Space (Flacco, De Luca & Khatib 2012, Algorithm 1, masking fix).

    Joints that would leave ``[q_min, q_max]`` within one period ``dt`` (or
    exceed ``v_max``) are saturated one at a time; the task ``ẋ = -λ e1 - ∂e1/∂t``
    is redistributed on the others and, if that is not enough, scaled by
    ``s ∈ [0, 1]`` keeping its direction (see the module docstring).
    """

    name = "sns"
    description = "saturation in the null space, task scaled when infeasible (Flacco et al. 2012)"

    KERNEL = LawKernel(
        "redservo.kernels.sns_law:sns_law",
        "J1 e q lp has_v has_a lam dt prev has_prev sec has_sec opt.v_max opt.has_v_max?"
        " opt.a_max opt.has_a_max? opt.margin opt.rcond opt.shield?",
        "redservo.kernels.events:sns_events",
        "m out.rank out.scale out.restored?",
        outputs={"restored": ("i", 5), "bad_joint": ("i", 6), "clipped": ("f", 3)},
    )
    OPTIONS, SLOTS = slotted(
        (
            Option(
                "v_max",
                None,
                kind="per-joint",
                doc="joint velocity limits (None: only the position limits bound the velocity)",
                unit="rad/s or m/s",
                ref="Flacco et al. 2012; docs/formulas.md §10.4",
                none=True,
                slot_kind="v",
            ),
            Option(
                "a_max",
                None,
                kind="per-joint",
                doc="joint acceleration limits for the braking bound √(2 a_max d), or None",
                unit="rad/s² or m/s²",
                ref="Flacco et al. 2012; docs/formulas.md §10.4",
                none=True,
                slot_kind="v",
            ),
            Option(
                "margin",
                1.0,
                doc="factor applied to the velocity bounds",
                low=0.0,
                high=1.0,
                low_open=True,
                slot_kind="f",
            ),
            RCOND,
        ),
        packed=(("has_v_max", "i"), ("has_a_max", "i")),
    )
    v_max: FloatArray | None
    a_max: FloatArray | None
    margin: float

    def packed_extras(self) -> tuple[tuple[tuple[str, int], float], ...]:
        """Also whether ``v_max`` and ``a_max`` are given."""
        has = (
            (self.SLOTS["has_v_max"], int(self.v_max is not None)),
            (self.SLOTS["has_a_max"], int(self.a_max is not None)),
        )
        return (*super().packed_extras(), *has)

    def _kernel(self, x: LawInputs) -> tuple[Any, ...]:
        """The law kernel's outputs (:func:`redservo.kernels.sns.sns`) for ``x``."""
        n = x.J1.shape[1]
        k = kernel_inputs(x)
        v, has_v = optional(None if self.v_max is None else _per_joint(self.v_max, n, "v_max"), n)
        a, has_a = optional(None if self.a_max is None else _per_joint(self.a_max, n, "a_max"), n)
        prev, has_prev = optional(x.qdot_prev, n)
        rates = (v, has_v, a, has_a)
        return tuple(
            _K.sns(
                k.J1,
                k.e,
                k.q,
                k.lp,
                k.has_v,
                k.has_a,
                x.lam,
                x.dt,
                prev,
                has_prev,
                k.sec,
                k.has_sec,
                *rates,
                self.margin,
                self.rcond,
                self.shield,
            )
        )

    def __call__(self, **kwargs: Any) -> LawResult:
        """:meth:`Law.__call__`; with a run's collision avoidance on and a command that
        breaks a velocity-damper row, Algorithm 1 again over the joints and the rows
        (:mod:`redservo.redundancy.sns_rows`)."""
        res = super().__call__(**kwargs)
        if getattr(self, "_distance_source", None) is None:
            return res
        x = validate_inputs(**kwargs)
        rows = distance_rows(self, x.q)
        if rows is None or rows_hold(rows, res.qdot):
            return res
        return with_rows(self, x, rows, self._kernel(x), res)

    def compute(self, x: LawInputs) -> LawResult:
        m = x.J1.shape[0]
        out = self._kernel(x)
        (
            qdot,
            scale,
            saturated,
            iterations,
            free_null,
            restored,
            clipped,
            rank,
            noted,
            bad,
            lo,
            hi,
        ) = out
        if bad >= 0:
            _infeasible(int(bad), lo, hi, x.q, x.limits, x.dt)
        task_rank = int(rank)
        sat = tuple(int(i) for i in np.flatnonzero(saturated))
        scale = float(scale)
        mask, vals, src = _KE.sns_events(m, task_rank, scale, bool(restored))
        info: list[str] = []
        if noted:
            info.append(f"final clip to the velocity bounds moved q̇ by {float(clipped):.3g}")
        diag = Diagnostics(
            method=self.name,
            task_rank=task_rank,
            rank_deficient=task_rank < m,
            projector_rank=int(free_null),
            critical=(sat,) if sat else (),
            iterations=int(iterations),
            overconstrained=scale < 1.0,
            scale=scale,
            events=events(mask, vals, src, rank=task_rank, m=m),
            info=tuple(info),
        )
        return LawResult(qdot, diag)
