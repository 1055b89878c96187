"""Velocity-level bounded least squares: the main task over hard joint limits (docs/formulas.md §10.5).

::

    min_q̇  ‖J1 q̇ + λ e_eff‖² + ε ‖q̇ - secondary‖²
    s.t.   q̇_min <= q̇ <= q̇_max
    q̇_min,i = max(-v_max,i, k_p (q_min,i + margin Δq_i - q_i)/dt)
    q̇_max,i = min( v_max,i, k_p (q_max,i - margin Δq_i - q_i)/dt),   0 < k_p <= 1

This is the two-level cascade of Kanoun, Lamiraux & Wieber (T-RO 2011) with the
joint limits as the (feasible, slack-free) top level and the task below it; the
small ``ε`` stands in for the minimum-norm third level. With ``k_p <= 1`` and
``margin >= 0``, ``q + q̇ dt`` never leaves ``[q_min, q_max]``. Unlike ``sns``,
the least-squares solution may change the *direction* of the task velocity
when the task is infeasible.

Decisions (the paper is silent or ambiguous; listed for docs/decisions.md):

* **ε is relative**: ``ε = eps · σ_max(J1)²`` (``eps`` default 1e-6), so that it
  has the units of ``J1^T J1`` and the same meaning for any feature scaling;
  ``ε = eps`` if ``J1 = 0``.
* **Fast path**: if the exact cascade solution without bounds,
  ``q̇* = J1⁺ ẋ + J1^⊥ secondary`` (the ε → 0 limit, i.e. the classical law),
  satisfies the bounds, it is returned as is without calling a solver. Only
  when bounds are active is the ε-regularized problem solved. Its solution
  differs from the exact lexicographic optimum by O(ε), so it is then
  *polished*: the joints at a bound stay there and the others get the exact
  minimum-``‖q̇ - secondary‖`` least-squares solution on that active set; the
  polish is kept only if it respects the bounds and does not increase the task
  residual (in random tests it always reached a task residual no larger than
  that of ``sns``, which the ε-solution alone did not).
* **``secondary``** is the lowest-priority preferred velocity: it replaces 0 in
  the ε-level (``ε ‖q̇ - secondary‖²``), so it acts only in the directions the
  task and the bounds leave free.
* **Defaults** ``k_p = 1`` and ``margin = 0``: the same feasible set as ``sns``
  (position bounds ``(q_lim - q)/dt``), so that the two baselines differ only
  by least squares versus scaling. CM01's ρ band is *not* used: it marks where
  avoidance starts acting, not a forbidden zone. ``margin`` is a fraction of the
  range in [0, 0.5).
* **Inside the margin band** the bound excludes 0 and pushes the joint back
  toward the allowed region (``q̇_min > 0`` near ``q_min``). ``q̇_min <= q̇_max`` holds
  by construction except when the push-back exceeds ``v_max``; the velocity
  limit then wins and the joint is fixed at ``±v_max`` toward the allowed
  region (reported in ``notes``). Options that are invalid raise
  :class:`~redservo.errors.ConfigurationError`; a control step never raises.
* Variables whose bounds coincide are eliminated before solving.
* **Solvers**: ``solver="auto"`` (or ``"active-set"``) is the compiled primal active-set
  method of :mod:`redservo.kernels.boxqp` on the reduced problem (a strictly convex QP in a
  box; the same minimiser as daqp to 1e-9, tests/test_boxqp.py): no Python call per step,
  no optional dependency, and the one solver of every path (the law object, the compiled
  ``qp`` step, the campaign loop), so their commands are the same bit for bit. Should it
  fail (a box with ``q̇_min > q̇_max`` after the safety box, a non-finite number, its
  iteration cap), :func:`scipy.optimize.lsq_linear` (``bvls``) solves
  ``[J1; √ε I] q̇ ≈ [ẋ; √ε secondary]``, and if that fails too the unconstrained solution
  is clipped to the bounds; either is noted and flagged ``solver-fallback``.
  ``"scipy"`` forces the scipy solver; a :mod:`qpsolvers` backend name (``"daqp"``,
  ``"proxsuite"``, ``"quadprog"``; extra ``redservo[qp]``, imported lazily; daqp is called
  directly) selects that library, the reference the compiled solver is checked against
  (:mod:`redservo.redundancy.bls`; its failures fall back the same way). Campaigns run
  those library solves from Python (the compiled loop hands the step back), the default
  compiled one inside the loop. The result is always clipped to the bounds to remove
  solver tolerance.
* **Distance rows** (collision avoidance on, :mod:`redservo.redundancy.distance_rows`): the
  velocity dampers ``J_k q̇ ≥ b_k`` of the pairs within ``d_influence`` join the bounds as
  linear inequalities unless the unconstrained optimum meets them: the full problem (no
  polish) is solved by the compiled dual active-set method of :mod:`redservo.kernels.rowqp`
  (Goldfarb & Idnani; daqp's minimiser to 1e-9, tests/test_rowqp.py), the one solver of the
  law object and of the campaign loop, so their commands are the same bit for bit. When
  even "never closer" (``b_k`` capped at 0) is infeasible within the bounds the rows are
  dropped for the step (noted) and the distance shield guards; should the solver fail (its
  iteration cap, a numerical failure) the rows are dropped too, noted and flagged
  ``solver-fallback``.
* **Safety** (docs/safety.md): the bounds are intersected with the shield's box
  (velocity and acceleration limits of ``limits``, position limits less their margin,
  braking bound), so that ``qp`` satisfies them without the shield; the result is
  moved by whole float64 steps so that ``q + dt q̇`` is within the limits exactly.
* Diagnostics: ``critical = ((joints at a bound),)`` (only when a solver ran),
  ``notes`` name the solver and the relative task residual,
  ``overconstrained`` = relative residual ``‖J1 q̇ - ẋ‖/‖ẋ‖ > 1e-3`` (the bounds
  prevent the task; well above the O(ε) bias).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.kernels import lazy
from redservo.limits import JointLimits
from redservo.redundancy.base import RCOND, Diagnostics, Law, LawInputs, LawResult, register
from redservo.redundancy.bls import (
    daqp_once,
    qpsolvers_module,
    solve_bounded_least_squares,
)
from redservo.redundancy.distance_rows import (
    ROWS_FAILED,
    distance_rows,
    rows_hold,
    solve_qp_rows,
)
from redservo.redundancy.flags import Event
from redservo.redundancy.kio import KernelInputs, LawOutputs, kernel_inputs, optional
from redservo.redundancy.linalg import DEFAULT_RCOND
from redservo.redundancy.options import Option
from redservo.redundancy.packs import limits_pack
from redservo.redundancy.qp_step import (
    ACTIVE_SET,
    INSIDE_NOTE,
    qp_diagnose,
    qp_diagnostics,
    qp_pack,
    v_per_joint,
)

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import boxqp as _KB
    from redservo.kernels import events as _KE
    from redservo.kernels import qp as _K
else:
    _K = lazy("qp")
    _KB = lazy("boxqp")
    _KE = lazy("events")

__all__ = ["ACTIVE_SET", "BoundedLeastSquares", "qp_velocity_bounds", "solve_bounded_least_squares"]

ROW_SOLVER = "dual active-set (with distance rows)"
"""The solver note of a step solved with the distance rows (:mod:`redservo.kernels.rowqp`)."""
_FAILURES = {-1: "the bounds do not meet", 0: "numerical failure or iteration cap"}
"""The compiled solver's status codes that are not a solution, in words."""


def qp_velocity_bounds(
    q: FloatArray,
    limits: JointLimits,
    dt: float,
    *,
    k_p: float = 1.0,
    margin: float = 0.0,
    v_max: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, tuple[int, ...]]:
    """Return ``(q̇_min, q̇_max, conflicts)``, the (n,) bounds of the QP (docs/formulas.md §10.5).

    ``conflicts`` lists the joints whose push-back toward the allowed region
    exceeds ``v_max``; their velocity is fixed at ``±v_max`` (``q̇_min = q̇_max``).

    Args:
        q: (n,) joint positions (m or rad).
        limits: The joint limits.
        dt: Control period (s).
        k_p: Gain in (0, 1] on the position bounds.
        margin: Keep-out band at each limit, fraction of the range in [0, 0.5).
        v_max: Velocity limits, 0-d or (n,) array (rad/s or m/s), or None.
    """
    n = q.shape[0]
    v, has_v = optional(None if v_max is None else v_per_joint(v_max, n), n)
    lo, hi, conflicts = _K.qp_velocity_bounds(
        np.ascontiguousarray(q, dtype=np.float64),
        limits_pack(limits).rows,
        float(dt),
        float(k_p),
        float(margin),
        v,
        has_v,
    )
    return lo, hi, tuple(int(i) for i in np.flatnonzero(conflicts))


_v_per_joint = v_per_joint
"""``v_max`` per joint (:func:`redservo.redundancy.qp_step.v_per_joint`; its former home)."""


def _levels(active: NDArray[np.bool_]) -> tuple[tuple[int, ...], ...]:
    """``critical``: the joints at a bound, as one level (none: no level)."""
    at = tuple(int(i) for i in np.flatnonzero(active))
    return (at,) if at else ()


@register
class BoundedLeastSquares(Law):
    """``min ‖J1 q̇ + λ e_eff‖² + ε‖q̇‖²`` s.t. velocity bounds from the joint limits (KLW 2011).

    See the module docstring for the bounds, the fast path and the solvers.
    """

    name = "qp"
    description = "bounded least squares min‖J1q̇ + λe1‖² s.t. joint-velocity bounds (KLW 2011)"

    OPTIONS = (
        Option(
            "eps",
            1e-6,
            doc="relative regularization, ε = eps σ_max(J1)²",
            ref="KLW 2011",
            low=0.0,
            low_open=True,
        ),
        Option(
            "k_p",
            1.0,
            doc="gain on the position bounds",
            ref="KLW 2011",
            low=0.0,
            high=1.0,
            low_open=True,
        ),
        Option(
            "margin",
            0.0,
            doc="keep-out band at each limit, a fraction of the joint range",
            low=0.0,
            high=0.5,
            high_open=True,
        ),
        Option(
            "v_max",
            None,
            kind="per-joint",
            doc="joint velocity limits, or None",
            unit="rad/s or m/s",
            none=True,
        ),
        Option(
            "solver",
            "auto",
            kind="str",
            doc="'auto' or 'active-set' (the compiled active-set solver), 'scipy' or an "
            "installed qpsolvers backend (daqp, proxsuite, quadprog)",
        ),
        RCOND,
    )
    eps: float
    k_p: float
    margin: float
    v_max: FloatArray | None
    solver: str

    def _setup(self) -> None:
        solver = self.solver
        if solver not in ("auto", ACTIVE_SET, "scipy"):
            qps = qpsolvers_module()
            available = list(qps.available_solvers) if qps is not None else []
            if solver not in available:
                hint = (
                    f"installed qpsolvers backends: {', '.join(available) or 'none'}"
                    if qps is not None
                    else "qpsolvers is not installed (pip install 'redservo[qp]')"
                )
                raise ConfigurationError(
                    f"solver must be 'auto', {ACTIVE_SET!r}, 'scipy' or an installed qpsolvers "
                    f"backend; got {solver!r} ({hint})",
                    argument="solver",
                )

    def _resolve_backend(self) -> str:
        """The backend name for this instance: ``"auto"`` is :data:`ACTIVE_SET`."""
        return ACTIVE_SET if self.solver == "auto" else self.solver

    def compute(self, x: LawInputs) -> LawResult:
        m, n = x.J1.shape
        k = kernel_inputs(x)
        v, has_v = optional(None if self.v_max is None else v_per_joint(self.v_max, n), n)
        prev, has_prev = optional(x.qdot_prev, n)
        out = _K.qp_setup(
            k.J1,
            k.e,
            k.q,
            k.lp,
            k.has_v,
            k.has_a,
            x.dt,
            prev,
            has_prev,
            k.sec,
            k.has_sec,
            x.lam,
            self.k_p,
            self.margin,
            v,
            has_v,
            self.rcond,
            self.eps,
            self.shield,
        )
        qdot, inside, lo, hi, conflicts, xdot, rank, eps_abs, xfix, free, P, c, lof, hif = out
        info: list[str] = []
        critical: tuple[tuple[int, ...], ...] = ()
        used, resid = "", -1.0
        rowed = self._rows(k, x, xdot, lo, hi, float(eps_abs), qdot if inside else None, info)
        rows_failed = bool(info) and info[-1].startswith(ROWS_FAILED)
        if rowed is not None:
            fixed, active, resid = _K.qp_finish(k.J1, xdot, lo, hi, rowed, k.q, x.dt, k.lp)
            used, resid, critical = ROW_SOLVER, float(resid), _levels(active)
        elif inside:
            info.append(INSIDE_NOTE)
            fixed, _, _ = _K.qp_finish(k.J1, xdot, lo, hi, qdot, k.q, x.dt, k.lp)
        else:
            qp = (xfix, free, P, c, lof, hif)
            fixed, used, active, resid = self._solve(k, x, xdot, lo, hi, float(eps_abs), qp)
            info.append(f"solver: {used}")
            critical = _levels(active)
            if resid >= 0.0:
                info.append(f"relative task residual {resid:.3g}")
        fallback = "fallback" in used or "failed" in used or rows_failed
        found = _KE.qp_events(m, int(rank), conflicts, fallback, resid)
        solver = (used, resid, critical)
        has_sec = x.secondary is not None
        diag = qp_diagnostics(self.name, (m, n), int(rank), solver, conflicts, found, has_sec, info)
        return LawResult(fixed, diag)

    def diagnose(self, m: int, out: LawOutputs, more: tuple[Event, ...] = ()) -> Diagnostics:
        """The diagnostics of the compiled Controller step's outputs ``out`` (m task rows;
        ``more``: the safety layer's events; :mod:`redservo.kernels.qp_control`), as
        :meth:`compute` builds them (:func:`~redservo.redundancy.qp_step.qp_diagnose`)."""
        return qp_diagnose(self, m, out, more)

    def control_pack(self, n: int) -> tuple[Any, ...]:
        """The options packed for the compiled Controller step with ``n`` joints
        (:func:`~redservo.redundancy.qp_step.qp_pack`).

        Raises:
            ConfigurationError: the law has no compiled step (a solver library, distance
                rows) or ``v_max`` does not fit ``n`` joints.
        """
        return qp_pack(self, n)

    def _rows(
        self,
        k: KernelInputs,
        x: LawInputs,
        xdot: FloatArray,
        lo: FloatArray,
        hi: FloatArray,
        eps_abs: float,
        free: FloatArray | None,
        info: list[str],
    ) -> FloatArray | None:
        """The solution with the distance rows (module docstring), or None: no row, the
        unconstrained optimum ``free`` (None: not within the bounds) meets them, or no
        solution (noted in ``info``)."""
        rows = distance_rows(self, k.q)
        if rows is None or (free is not None and rows_hold(rows, free)):
            return None
        rowed, note = solve_qp_rows(k.J1, xdot, lo, hi, eps_abs, x.secondary, rows)
        info.append(note)
        return rowed

    def _solve(
        self,
        k: KernelInputs,
        x: LawInputs,
        xdot: FloatArray,
        lo: FloatArray,
        hi: FloatArray,
        eps_abs: float,
        qp: tuple[Any, ...],
    ) -> tuple[FloatArray, str, NDArray[np.bool_], float]:
        """The bounded least squares with the solver, then the polish and the final checks:
        ``(q̇, solver note, joints at a bound, relative residual)``. The compiled solver
        (:data:`ACTIVE_SET`) and daqp take the problem reduced by the kernel; any other
        backend or a failure takes the general path of :func:`solve_bounded_least_squares`."""
        xfix, free, P, c, lof, hif = qp
        backend, why = self._resolve_backend(), ""
        if backend == ACTIVE_SET:
            kin = (k.sec, k.has_sec, k.q, x.dt, k.lp)
            fixed, polished, active, resid, status = _KB.qp_solve_reduced(
                k.J1, xdot, lo, hi, xfix, free, P, c, lof, hif, *kin
            )
            if status == _KB.SOLVED:
                used = f"{ACTIVE_SET} + active-set polish" if polished else ACTIVE_SET
                return fixed, used, active, float(resid)
            why = f"{ACTIVE_SET} failed ({_FAILURES[int(status)]}); fallback "
            backend = "scipy"
        xf = None
        if free.size and backend == "daqp":
            daqp = daqp_once()
            if daqp is not None:
                nf = free.size
                sense = np.zeros(nf, dtype=np.intc)
                y, _, exitflag, _ = daqp.solve(P, c, np.zeros((0, nf)), hif, lof, sense)
                if exitflag > 0 and np.isfinite(y).all():
                    xf = np.ascontiguousarray(y, dtype=np.float64)
        if xf is not None:
            fixed, polished, active, resid = _K.qp_complete(
                k.J1, xdot, lo, hi, xfix, free, xf, k.sec, k.has_sec, DEFAULT_RCOND, k.q, x.dt, k.lp
            )
            return fixed, "daqp + active-set polish" if polished else "daqp", active, float(resid)
        sol, used = solve_bounded_least_squares(
            k.J1, xdot, lo, hi, eps=eps_abs, z=x.secondary, solver=backend
        )
        fixed, active, resid = _K.qp_finish(k.J1, xdot, lo, hi, sol, k.q, x.dt, k.lp)
        return fixed, why + used, active, float(resid)
