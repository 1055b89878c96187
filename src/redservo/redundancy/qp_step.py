"""The ``qp`` law's diagnostics, and the packs of its compiled Controller step.

:func:`qp_diagnostics` is the one construction of ``qp``'s :class:`~redservo.Diagnostics`
(formulas and decisions: :mod:`redservo.redundancy.qp`): its own ``compute`` calls it with
what its kernels and solver returned, and :func:`qp_diagnose` (the law's ``diagnose``) with
what the compiled Controller step (:mod:`redservo.kernels.qp_control`) wrote into its buffer,
so the two paths say the same thing bit for bit. :func:`qp_pack` packs the law's options for
that step (:func:`redservo.kernels.qp_control.qp_core`'s layout); it raises when the law has
no compiled step (a solver library, distance rows), which the Controller reports as the
reason it runs the object path. Units: rad or m, s.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from redservo._validation import FloatArray
from redservo.errors import ConfigurationError
from redservo.kernels.flagbits import TASK_SCALED
from redservo.redundancy.flags import Event
from redservo.redundancy.kio import LawOutputs
from redservo.redundancy.messages import events

if TYPE_CHECKING:
    from redservo.redundancy.base import Diagnostics
    from redservo.redundancy.qp import BoundedLeastSquares

__all__ = [
    "ACTIVE_SET",
    "INSIDE_NOTE",
    "QP_STEP_ID",
    "qp_diagnose",
    "qp_diagnostics",
    "qp_pack",
    "v_per_joint",
]

ACTIVE_SET = "active-set"
"""The ``solver`` name of the compiled active-set solver (:mod:`redservo.kernels.boxqp`),
what ``"auto"`` means."""

INSIDE_NOTE = "solver: none (unconstrained optimum within the bounds)"
"""The solver note of a step whose unconstrained optimum is within the bounds."""
QP_STEP_ID = -1
"""The law id in :func:`qp_pack` (``qp`` has none in :data:`redservo.kernels.step.LAW_IDS`)."""
_SOLVED = ("", "active-set", "active-set + active-set polish")
"""The solver note of each code of ``iout[1]`` (:mod:`redservo.kernels.qp_control`)."""


def qp_diagnostics(
    name: str,
    shape: tuple[int, int],
    rank: int,
    solver: tuple[str, float, tuple[tuple[int, ...], ...]],
    conflicts: Any,
    found: tuple[int, Any, Any],
    has_sec: bool,
    info: Sequence[str],
    more: tuple[Event, ...] = (),
) -> Diagnostics:
    """``qp``'s diagnostics (:mod:`redservo.redundancy.qp`, "Diagnostics").

    Args:
        name: The law's name.
        shape: ``(m, n)`` of ``J1``.
        rank: The rank of ``J1``.
        solver: ``(solver note, relative task residual, critical)``: the note names the
            solver ("" when none ran), the residual is -1 when not computed, ``critical`` the
            joints at a bound as one level (none: no level).
        conflicts: (n,) the joints whose bounds conflict (booleans or 0/1).
        found: ``(mask, vals, src)`` of :func:`redservo.kernels.events.qp_events`.
        has_sec: A secondary command was given.
        info: The notes.
        more: Events to append (the safety layer's).
    """
    from redservo.redundancy.base import Diagnostics

    m, n = shape
    used, _, critical = solver
    mask, vals, src = found
    ctx: dict[str, Any] = {"rank": rank, "m": m, "solver": used}
    ctx["conflicts"] = lambda: np.flatnonzero(conflicts).tolist()
    said = events(mask, vals, src, **ctx)
    return Diagnostics(
        method=name,
        task_rank=rank,
        rank_deficient=rank < m,
        projector_rank=n - rank if has_sec else 0,
        critical=critical,
        overconstrained=bool(src[TASK_SCALED]),  # the bounds prevent the task
        events=(*said, *more) if more else said,
        info=tuple(info),
    )


def qp_diagnose(
    law: BoundedLeastSquares, m: int, out: LawOutputs, more: tuple[Event, ...] = ()
) -> Diagnostics:
    """The diagnostics of the compiled step's outputs ``out`` (m task rows; ``more``: the
    safety layer's events; layout: :mod:`redservo.kernels.qp_control`), as the law's own
    ``compute`` builds them for the same step."""
    iout, fout = out.iout, out.fout
    n = out.axes.shape[0]
    code, resid = int(iout[1]), float(fout[0])
    critical: tuple[tuple[int, ...], ...]
    if code == 0:
        used, info, critical = "", [INSIDE_NOTE], ()
    else:
        used = _SOLVED[code]
        info = [f"solver: {used}"]
        if resid >= 0.0:
            info.append(f"relative task residual {resid:.3g}")
        at = tuple(int(i) for i in np.flatnonzero(out.axes))
        critical = (at,) if at else ()
    found = (out.mask, out.vals, out.src)
    solver = (used, resid, critical)
    return qp_diagnostics(
        law.name, (m, n), int(iout[0]), solver, out.vec, found, bool(iout[2]), info, more
    )


def v_per_joint(v_max: FloatArray, n: int) -> FloatArray:
    """``qp``'s ``v_max`` (rad/s or m/s, 0-d or (n,)) as one value per joint.

    Raises:
        ConfigurationError: ``v_max`` has another number of entries than ``n``.
    """
    v = np.full(n, float(v_max)) if v_max.ndim == 0 else v_max
    if v.shape != (n,):
        raise ConfigurationError(
            f"v_max has {v.shape[0]} entries but the robot has {n} joints; give a scalar or "
            f"one value per joint"
        )
    return v


def qp_pack(law: BoundedLeastSquares, n: int) -> tuple[Any, ...]:
    """``(law id, fopt, iopt, vopt)`` of the compiled step for ``n`` joints
    (:mod:`redservo.kernels.qp_control`).

    Raises:
        ConfigurationError: the law's solver is a library (its step runs the object path),
            it solves with distance rows, or its ``v_max`` does not fit ``n`` joints.
    """
    from redservo.redundancy.distance_rows import _SOURCE

    if law._resolve_backend() != ACTIVE_SET:
        raise ConfigurationError(
            f"method 'qp' with solver {law.solver!r} has no compiled step (its solver is a "
            f"Python library)",
            argument="solver",
        )
    if getattr(law, _SOURCE, None) is not None:
        raise ConfigurationError(
            "method 'qp' with distance rows (collision avoidance) has no compiled step",
            argument="collision",
        )
    vopt = np.zeros((2, n))
    if law.v_max is not None:
        vopt[0] = v_per_joint(law.v_max, n)
    fopt = np.array([law.rcond, law.eps, law.k_p, law.margin])
    iopt = np.array([int(law.shield), 1, int(law.v_max is not None), 0], dtype=np.int64)
    return QP_STEP_ID, fopt, iopt, vopt
