"""What a law returned, checked, and the final guard on a user's own law.

:class:`~redservo.control.Controller` accepts any callable as its law. A shipped law
(:func:`redservo.make_law`) checks its own command in its safety layer (docs/safety.md:
finite, within the velocity and acceleration limits and, shield on, the position limits,
every change reported as a typed flag). A user's own law gets the same guarantees here:

1. :func:`law_output`: the result must carry ``qdot``, an (n,) array of numbers, and may
   carry ``diagnostics``; anything else is one :class:`~redservo.errors.ShapeError` naming
   the law and what is allowed (a list, a bare array, the wrong length, strings);
2. :func:`guarded_output`: the servo loop's final guard
   (:func:`~redservo.control.guard.guard_command`) on that command, with the controller's
   period: NaN/inf replaced by zeros, the whole command scaled into ``qdot_max``, its change
   into ``qddot_max·dt``, and (unless the law says ``shield = False``) no joint moving past
   its safe range within one period. Every change is added to the diagnostics as the flag
   a shipped law raises for it (``non-finite-replaced``, ``velocity-scaled``,
   ``acceleration-limited``, ``shield-acted``, ``acceleration-exceeded``), so the
   simulator logs it, ``redservo run`` prints it and a servo loop stops on a non-finite
   command as it does for a shipped law.

Units: rad/s or m/s per joint for commands, s for ``dt``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from redservo._validation import FloatArray
from redservo.control.guard import GuardReport, guard_command
from redservo.errors import ShapeError
from redservo.limits import JointLimits
from redservo.redundancy.base import Diagnostics
from redservo.redundancy.flags import Event, Flag

__all__ = ["guarded_output", "law_name", "law_output"]


def law_name(law: object) -> str:
    """The name a law is reported by: its ``name``, else its function or class name."""
    name = getattr(law, "name", None) or getattr(law, "__name__", None)
    return str(name or type(law).__name__)


def law_output(result: object, law: object, n: int) -> tuple[FloatArray, Diagnostics]:
    """The command (n,) and the diagnostics of what ``law`` returned (module docstring).

    Raises:
        ShapeError: ``result`` has no ``qdot``, or ``qdot`` is not (n,) numbers; the error's
            ``argument`` is ``"law"``.
    """
    name = law_name(law)
    allowed = (
        f"a law returns an object with .qdot, an ({n},) array of joint velocities "
        "(rad/s or m/s), and .diagnostics (redservo.LawResult)"
    )
    if not hasattr(result, "qdot"):
        raise ShapeError(
            f"law {name!r} returned {type(result).__name__} {_short(result)}: {allowed}",
            argument="law",
        )
    raw: Any = result.qdot
    try:
        qdot = np.asarray(raw, dtype=float)
        kind = np.asarray(raw).dtype.kind
    except (TypeError, ValueError):
        qdot, kind = np.empty(0), "O"
    if kind not in "biuf" or qdot.shape != (n,):
        got = f"shape {qdot.shape}" if kind in "biuf" else _short(raw)
        raise ShapeError(f"law {name!r} returned qdot = {got}: {allowed}", argument="law")
    diag = getattr(result, "diagnostics", None)
    if not isinstance(diag, Diagnostics):
        diag = Diagnostics(method=name, info=() if diag is None else (f"diagnostics: {diag!r}",))
    return qdot, diag


def guarded_output(
    qdot: FloatArray,
    diag: Diagnostics,
    *,
    q: FloatArray,
    qdot_prev: FloatArray | None,
    limits: JointLimits,
    dt: float,
    shield: bool,
) -> tuple[FloatArray, Diagnostics, GuardReport]:
    """The guarded command, the diagnostics with a flag for each change, and the guard's
    report (module docstring). ``qdot_prev`` None (unknown previous motion) leaves the
    acceleration limits out, as the shipped laws do."""
    if qdot_prev is None:  # unknown previous motion: no acceleration bound
        prev = np.zeros_like(qdot)
        if limits.qddot_max is not None:
            limits = limits.replace(qddot_max=None)
    else:
        prev = np.asarray(qdot_prev, dtype=float)
    cmd, report = guard_command(
        qdot, q=q, qdot_prev=prev, limits=limits, period=dt, position=shield
    )
    events = _events(qdot, cmd, report, prev, limits, dt)
    if events:
        diag = dataclasses.replace(diag, events=(*diag.events, *events))
    return cmd, diag, report


def _events(
    raw: FloatArray,
    cmd: FloatArray,
    report: GuardReport,
    prev: FloatArray,
    limits: JointLimits,
    dt: float,
) -> list[Event]:
    """One event per change the guard made, as a shipped law reports it."""
    out: list[Event] = []
    if report.non_finite:
        count = int(np.sum(~np.isfinite(raw)))
        out.append(
            Event(
                Flag.NON_FINITE_REPLACED,
                float(count),
                f"the law returned {count} non-finite entries: zeros sent",
            )
        )
        return out
    if report.velocity_scale < 1.0:
        out.append(
            Event(
                Flag.VELOCITY_SCALED,
                report.velocity_scale,
                f"command scaled by {report.velocity_scale:.3g} into qdot_max",
            )
        )
    if report.acceleration_scale < 1.0:
        out.append(
            Event(
                Flag.ACCELERATION_LIMITED,
                report.acceleration_scale,
                f"change of command scaled by {report.acceleration_scale:.3g}",
            )
        )
    if report.position_clipped:
        joints = ", ".join(f"q{i + 1}" for i in report.position_clipped)
        change = float(np.max(np.abs(cmd - raw * report.velocity_scale)))
        out.append(
            Event(Flag.SHIELD_ACTED, change, f"the guard kept {joints} within the safe range")
        )
    if report.acceleration_exceeded and limits.qddot_max is not None:
        excess = float(np.max(np.abs(cmd - prev) / dt - limits.qddot_max))
        out.append(
            Event(
                Flag.ACCELERATION_EXCEEDED,
                excess,
                "the position limits outranked the acceleration limit",
            )
        )
    return out


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
