"""Velocity-damper rows on ``q̇`` for the optimisation laws (``qp``, ``sns``, ``predictive``).

With a run's collision avoidance on (:class:`~redservo.control.avoidance.Collision`,
``enabled``, ``avoid``), every pair ``k`` closer than ``d_i`` (``d_influence``, m) gives the
velocity damper of Faverjon & Tournassoud (1987) as a linear inequality on the command::

    ḋ_k = J_k q̇ + ∂d_k/∂t  ≥  −ξ (d_k − d_s)/(d_i − d_s)            (m/s)
    i.e.  J_k q̇ ≥ b_k = −ξ (d_k − d_s)/(d_i − d_s) − ∂d_k/∂t

(``J_k`` the distance Jacobian, m/rad or m/m; ``ξ`` = ``Collision.xi``, m/s, the approach
speed allowed at ``d_i``; ``d_s`` = ``d_safe``). The allowed approach speed falls linearly
to 0 at ``d_s`` and, inside ``d_s``, the row asks the pair to separate. The rows are what
the law solves for: ``qp`` adds them to its QP (:func:`solve_qp_rows`), ``sns`` saturates
them as it saturates joints (:mod:`redservo.redundancy.sns_rows`), ``predictive`` adds them
on its first command. The repulsive secondary and the distance shield stay in place.

A law gets its rows through :func:`bind_distances` (the Controller's collision check calls
it); :func:`distance_rows` measures them at the law's ``q``, at the time of the collision
set-up's last measurement (the repulsive objective measures first in the same step). The
compiled campaign loop builds the same rows itself (:mod:`redservo.kernels.loop_rows`) and,
when a step needs the law's Python solve, calls the law with them (:func:`given_rows`). ``qp`` and ``sns`` solve and decide with compiled kernels that
both paths call (:func:`solve_qp_rows`, :func:`rows_hold`, :mod:`redservo.kernels.sns_rows`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.kernels.row_tolerance import ROW_TOL

if TYPE_CHECKING:
    from redservo.control.avoidance import Collision
    from redservo.kernels import loop_rows as _KL
    from redservo.kernels import rowqp as _KR
    from redservo.robots.base import Robot
else:
    _KR = lazy("rowqp")
    _KL = lazy("loop_rows")

__all__ = [
    "ROW_LAWS",
    "ROW_TOL",
    "DistanceRows",
    "bind_distances",
    "distance_rows",
    "given_rows",
    "row_report",
    "rows_hold",
    "solve_qp_rows",
]

_SOURCE = "_distance_source"
"""The attribute of a law holding its ``(collision, robot)`` (or None)."""
ROWS_FAILED = "distance rows: the compiled row solver failed"
"""The start of :func:`solve_qp_rows`' note when its solver fails (the law then flags
``solver-fallback``)."""


class DistanceRows(NamedTuple):
    """``G q̇ ≥ b`` for the pairs within ``d_influence`` (module docstring)."""

    G: FloatArray
    """(r, n) the pairs' distance Jacobians (m/rad or m/m)."""
    b: FloatArray
    """(r,) the damper's bounds (m/s)."""
    names: tuple[str, ...]
    """(r,) the pairs."""

    def satisfied(self, qdot: FloatArray) -> bool:
        """Whether ``qdot`` (rad/s or m/s) meets every row."""
        return bool(np.all(self.G @ qdot >= self.b - ROW_TOL))


ROW_LAWS = ("qp", "sns", "predictive")
"""The laws that solve with the rows; the others avoid through their secondary term."""


def bind_distances(law: object, collision: Collision | None, robot: Robot) -> None:
    """Give ``law`` (one of :data:`ROW_LAWS`) the collision set-up of its controller, or take
    it away (``collision`` None or not avoiding)."""
    if getattr(law, "name", None) not in ROW_LAWS:
        return
    on = collision is not None and collision.enabled and collision.avoid and collision.active
    object.__setattr__(law, _SOURCE, (collision, robot) if on else None)
    law.__dict__.pop("_kernel_pack", None)  # a compiled step bound without rows is stale
    inner = getattr(law, "_fallback", None)  # the predictive law's qp, when its solve fails
    if inner is not None:
        bind_distances(inner, collision, robot)


def distance_rows(law: object, q: FloatArray) -> DistanceRows | None:
    """The rows of ``law`` at ``q`` (rad or m): None without a bound collision set-up or when
    no pair is within ``d_influence``."""
    src: tuple[Collision, Robot] | DistanceRows | None = getattr(law, _SOURCE, None)
    if src is None or isinstance(src, DistanceRows):
        return src
    c, robot = src
    pd = c.measure(robot, q, c.last_time)
    near = pd.d < c.d_influence
    if not np.any(near):
        return None
    ramp = c.xi * (pd.d[near] - c.d_safe) / (c.d_influence - c.d_safe)
    names = tuple(nm for nm, k in zip(pd.names, near, strict=True) if k)
    return DistanceRows(np.ascontiguousarray(pd.J[near]), -ramp - pd.drift[near], names)


@contextmanager
def given_rows(law: object, rows: DistanceRows | None) -> Iterator[None]:
    """Within the block, ``law``'s rows are ``rows`` (None: none), whatever its ``q``: the
    rows the compiled campaign loop built at the ``q`` it calls the law at
    (:mod:`redservo.kernels.loop_rows`). The law's own set-up is restored afterwards."""
    saved = getattr(law, _SOURCE, None)
    object.__setattr__(law, _SOURCE, rows)
    try:
        yield
    finally:
        object.__setattr__(law, _SOURCE, saved)


def rows_hold(rows: DistanceRows, qdot: FloatArray) -> bool:
    """Whether ``qdot`` (rad/s or m/s) meets every row by :data:`ROW_TOL`, by the compiled
    check the campaign loop makes (:func:`redservo.kernels.loop_rows.rows_met`): ``qp`` and
    ``sns`` decide with it on both paths, so the two decide alike to the bit."""
    return bool(_KL.rows_met(rows.G, rows.b, np.ascontiguousarray(qdot, dtype=np.float64)))


def solve_qp_rows(
    J1: FloatArray,
    xdot: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    eps: float,
    secondary: FloatArray | None,
    rows: DistanceRows,
) -> tuple[FloatArray | None, str]:
    """``min ‖J1 q̇ − ẋ‖² + ε ‖q̇ − secondary‖²`` s.t. ``lo ≤ q̇ ≤ hi`` and ``G q̇ ≥ b``
    with the compiled dual active-set solver (:func:`redservo.kernels.rowqp.qp_rows`, the
    one the campaign loop calls): ``(q̇, note)``, q̇ None when no solution exists even with
    the rows relaxed to "never closer" (``b`` capped at 0; the note says which was solved),
    or when the solver fails (the note starts with :data:`ROWS_FAILED`).

    Args:
        J1: (m, n) task Jacobian; xdot: (m,) task velocity.
        lo, hi: (n,) the law's velocity bounds (rad/s or m/s).
        eps: Absolute regularisation ε (units of ``J1ᵀ J1``).
        secondary: (n,) preferred joint velocity, or None.
        rows: The distance rows.
    """
    n = J1.shape[1]
    f64 = np.float64
    sec = np.zeros(n) if secondary is None else np.ascontiguousarray(secondary, dtype=f64)
    y, status, relaxed = _KR.qp_rows(
        np.ascontiguousarray(J1, dtype=f64),
        np.ascontiguousarray(xdot, dtype=f64),
        np.ascontiguousarray(lo, dtype=f64),
        np.ascontiguousarray(hi, dtype=f64),
        float(eps),
        sec,
        secondary is not None,
        np.ascontiguousarray(rows.G, dtype=f64),
        np.ascontiguousarray(rows.b, dtype=f64),
    )
    r = len(rows.b)
    if status == _KR.SOLVED:
        return y, f"distance rows: {r} ({'relaxed to 0' if relaxed else 'velocity dampers'})"
    if status == _KR.FAILED:
        return None, f"{ROWS_FAILED} (numerical failure or iteration cap); {r} rows dropped"
    return None, f"distance rows: {r} infeasible within the joint bounds"


def row_report(rows: DistanceRows | None, qdot: FloatArray) -> str:
    """One line on the rows the command leaves unmet (for ``info``), or ``""``."""
    if rows is None or rows.satisfied(qdot):
        return ""
    gap = rows.b - rows.G @ qdot
    k = int(np.argmax(gap))
    return f"distance row of {rows.names[k]} unmet by {gap[k]:.3g} m/s (the distance shield guards)"
