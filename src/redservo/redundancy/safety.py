"""The last stages of every control law: rate limits and the position shield (docs/safety.md).

A law's raw command ``q̇_des`` goes through two stages before it leaves
:meth:`redservo.redundancy.Law.__call__`:

1. **Rate limits** (always, when the limits carry them). The box
   ``R = [-q̇_max, q̇_max] ∩ [q̇_prev - q̈_max dt, q̇_prev + q̈_max dt]`` (the second
   term only when the previous command ``q̇_prev`` is known). The command is scaled
   into R keeping its direction: ``q̇ = a + s (q̇_des - a)`` with ``a`` the point of R
   closest to 0 (``a = 0`` unless the acceleration limit forbids stopping in one
   period) and the largest ``s ∈ [0, 1]``. ``scaling="uniform"`` (default) scales the
   whole command, so that axes the law stopped stay stopped and the task keeps its
   direction (``J1 q̇ = -s λ e1``); ``scaling="secondary-first"`` first scales the part
   of the command beyond the primary task, ``q̇_des - q̇_task``, and only then the task.
2. **Shield** (``shield=True``, the default). The box
   ``P = [(q_safe_min - q)/dt, (q_safe_max - q)/dt]`` with
   ``q_safe = q̄ ∓ margin``, tightened by the braking bound ``√(2 q̈_max d)`` when
   acceleration limits are known (the joint can still stop before its safe limit).
   The command is clamped per joint into ``P ∩ R`` (the smallest change); then every
   joint is moved by whole float64 steps until ``q + dt·q̇`` lies within
   ``[q_safe_min, q_safe_max]`` *exactly* as the robot computes it. A joint that
   already lies in the margin band may not move further out, and returns at most at
   its velocity limit.

Priorities when the boxes conflict: the velocity limit, then the position shield, then
the acceleration limit (its excess is reported as ``ACCELERATION_EXCEEDED``).

Everything here works on plain float64 arrays (n,); units rad/s (m/s), rad/s² (m/s²), s.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from redservo._validation import FloatArray
from redservo.limits import JointLimits
from redservo.redundancy.flags import Event, Flag

__all__ = [
    "SafetyOutcome",
    "apply_safety",
    "command_box",
    "exact_position_fix",
    "intersect_boxes",
    "position_box",
    "rate_box",
    "scale_into_box",
]

_TOL = 1e-12
"""Relative slack below which a command counts as inside a box (roundoff)."""


def rate_box(
    limits: JointLimits, dt: float, qdot_prev: FloatArray | None
) -> tuple[FloatArray, FloatArray, bool]:
    """Return ``(lo, hi, accel_dropped)``: the rate box R (module docstring).

    The acceleration part is dropped (``accel_dropped``) on the joints where it does not
    meet the velocity box (a previous command above the velocity limit).
    """
    n = limits.n
    v = limits.qdot_max
    lo = np.full(n, -np.inf) if v is None else -v
    hi = np.full(n, np.inf) if v is None else v.copy()
    dropped = False
    a = limits.qddot_max
    if a is not None and qdot_prev is not None:
        alo = qdot_prev - a * dt
        ahi = qdot_prev + a * dt
        nlo, nhi = np.maximum(lo, alo), np.minimum(hi, ahi)
        ok = nlo <= nhi
        dropped = not bool(ok.all())
        lo = np.where(ok, nlo, lo)
        hi = np.where(ok, nhi, hi)
    return lo, hi, dropped


def position_box(q: FloatArray, limits: JointLimits, dt: float) -> tuple[FloatArray, FloatArray]:
    """Return ``(lo, hi)``, the shield's box P of velocities keeping ``q + dt q̇`` safe."""
    d_hi = limits.safe_max - q  # < 0 when q lies in the upper margin band
    d_lo = q - limits.safe_min
    hi = d_hi / dt
    lo = -d_lo / dt
    a = limits.qddot_max
    if a is not None:  # braking bound: the joint can still stop before its safe limit
        hi = np.minimum(hi, np.sqrt(2.0 * a * np.maximum(d_hi, 0.0)))
        lo = np.maximum(lo, -np.sqrt(2.0 * a * np.maximum(d_lo, 0.0)))
    v = limits.qdot_max
    back = np.zeros_like(q) if v is None else -v  # retreat from the band at most at v
    hi = np.where(d_hi < 0.0, np.maximum(hi, back), hi)
    lo = np.where(d_lo < 0.0, np.minimum(lo, -back), lo)
    return lo, hi


def command_box(
    q: FloatArray, limits: JointLimits, dt: float, qdot_prev: FloatArray | None
) -> tuple[FloatArray, FloatArray]:
    """Return ``P ∩ R`` with the module's priorities (velocity, position, acceleration).

    This is the feasible set ``sns`` and ``qp`` optimize over, so that they satisfy the
    shield without it.
    """
    rlo, rhi, _ = rate_box(limits, dt, qdot_prev)
    plo, phi = position_box(q, limits, dt)
    lo, hi = np.maximum(rlo, plo), np.minimum(rhi, phi)
    bad = lo > hi
    if bad.any():  # drop the acceleration part where it conflicts with the position box
        vlo, vhi, _ = rate_box(limits, dt, None)
        lo = np.where(bad, np.maximum(vlo, plo), lo)
        hi = np.where(bad, np.minimum(vhi, phi), hi)
    return lo, hi


def intersect_boxes(
    lo: FloatArray, hi: FloatArray, lo2: FloatArray, hi2: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Intersect a law's own box with :func:`command_box`; where they do not meet, the
    command box (the limits' priorities) wins."""
    nlo, nhi = np.maximum(lo, lo2), np.minimum(hi, hi2)
    bad = nlo > nhi
    if bad.any():
        nlo = np.where(bad, lo2, nlo)
        nhi = np.where(bad, hi2, nhi)
    return nlo, nhi


def _max_scale(base: FloatArray, step: FloatArray, lo: FloatArray, hi: FloatArray) -> float:
    """Largest ``s ∈ [0, 1]`` with ``lo <= base + s step <= hi`` (``base`` inside the box)."""
    s = 1.0
    up = step > 0.0
    if up.any():
        s = min(s, float(np.min((hi[up] - base[up]) / step[up])))
    down = step < 0.0
    if down.any():
        s = min(s, float(np.min((lo[down] - base[down]) / step[down])))
    return max(s, 0.0)


def _inside(x: FloatArray, lo: FloatArray, hi: FloatArray) -> bool:
    slack = _TOL * (1.0 + np.abs(x))
    return bool(np.all((x >= lo - slack) & (x <= hi + slack)))


def scale_into_box(
    qdot: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    *,
    task: FloatArray | None = None,
) -> tuple[FloatArray, float]:
    """Scale ``qdot`` into ``[lo, hi]`` keeping its direction; return ``(q̇, s)``.

    Without ``task``: ``q̇ = a + s (qdot - a)``, ``a`` the point of the box closest to 0.
    With ``task`` (secondary-first): first ``q̇ = task + s (qdot - task)`` if ``task``
    is inside the box, else the task alone scaled toward ``a`` (``s`` is then that
    scale, and the rest is dropped). The result is clipped to the box (roundoff).
    """
    if _inside(qdot, lo, hi):
        return np.clip(qdot, lo, hi), 1.0
    anchor = np.clip(0.0, lo, hi)
    if task is not None and _inside(task, lo, hi):
        t = np.clip(task, lo, hi)
        s = _max_scale(t, qdot - task, lo, hi)
        return np.clip(t + s * (qdot - task), lo, hi), s
    base = qdot if task is None else task
    s = _max_scale(anchor, base - anchor, lo, hi)
    return np.clip(anchor + s * (base - anchor), lo, hi), s


def exact_position_fix(
    q: FloatArray, qdot: FloatArray, dt: float, limits: JointLimits
) -> FloatArray:
    """Move ``qdot`` by whole float64 steps until ``q + dt·q̇`` is within the safe limits.

    The target is ``[min(q_safe_min, q), max(q_safe_max, q)]``: a joint in the margin band
    may stay where it is. A few ``nextafter`` steps suffice (the box was already exact up
    to roundoff).
    """
    top = np.maximum(limits.safe_max, q)
    bottom = np.minimum(limits.safe_min, q)
    out = qdot
    for _ in range(64):
        nxt = q + dt * out
        over = nxt > top
        under = nxt < bottom
        if not (over.any() or under.any()):
            break
        out = out.copy() if out is qdot else out
        out[over] = np.nextafter(out[over], -np.inf)
        out[under] = np.nextafter(out[under], np.inf)
    return out


class SafetyOutcome(NamedTuple):
    """Result of :func:`apply_safety`."""

    qdot: FloatArray
    events: tuple[Event, ...]


def apply_safety(
    qdot: FloatArray,
    q: FloatArray,
    limits: JointLimits,
    dt: float,
    *,
    qdot_prev: FloatArray | None = None,
    shield: bool = True,
    task: FloatArray | None = None,
) -> SafetyOutcome:
    """Run the rate stage and the shield on a raw command (module docstring).

    Args:
        qdot: (n,) raw command of the law (rad/s or m/s); NaN/inf are replaced.
        q: (n,) current joint positions (m or rad).
        limits: Position, velocity and acceleration limits and the margin.
        dt: Control period (s).
        qdot_prev: (n,) previous command, for the acceleration limits, or None.
        shield: Apply the position shield.
        task: (n,) primary-task part of ``qdot`` for ``secondary-first`` scaling, or None
            for uniform scaling.
    """
    events: list[Event] = []
    if not np.isfinite(qdot).all():
        bad = int(np.count_nonzero(~np.isfinite(qdot)))
        events.append(
            Event(Flag.NON_FINITE_REPLACED, bad, f"{bad} non-finite entries: command replaced")
        )
        qdot = np.zeros_like(q)
        task = None
    if task is not None and not np.isfinite(task).all():
        task = None
    rlo, rhi, dropped = rate_box(limits, dt, qdot_prev)
    if shield:  # where the acceleration box misses the position box, the position wins
        plo, phi = position_box(q, limits, dt)
        clash = np.maximum(rlo, plo) > np.minimum(rhi, phi)
        if clash.any():
            vlo, vhi, _ = rate_box(limits, dt, None)
            rlo, rhi = np.where(clash, vlo, rlo), np.where(clash, vhi, rhi)
            dropped = True
    out, s = scale_into_box(qdot, rlo, rhi, task=task)
    if s < 1.0:
        v = limits.qdot_max
        over_v = v is not None and bool(np.any(np.abs(qdot) > v * (1.0 + _TOL)))
        flag = Flag.VELOCITY_SCALED if over_v else Flag.ACCELERATION_LIMITED
        events.append(Event(flag, s, f"command scaled by {s:.3g} into the rate limits"))
    if dropped:
        events.append(
            Event(
                Flag.ACCELERATION_EXCEEDED,
                np.nan,
                "acceleration limit released on some joints (it conflicted with the velocity "
                "or position limits, which win)",
            )
        )
    if shield:
        plo, phi = command_box(q, limits, dt, qdot_prev)
        clamped = np.clip(out, plo, phi)
        fixed = exact_position_fix(q, clamped, dt, limits)
        change = float(np.max(np.abs(fixed - out))) if out.size else 0.0
        if change > _TOL * (1.0 + float(np.max(np.abs(out)))):
            events.append(
                Event(Flag.SHIELD_ACTED, change, f"position shield changed q̇ by {change:.3g}")
            )
        if qdot_prev is not None and limits.qddot_max is not None:
            excess = np.abs(fixed - qdot_prev) - limits.qddot_max * dt
            worst = float(np.max(excess)) / dt
            if worst > _TOL * (1.0 + float(np.max(limits.qddot_max))) and not dropped:
                events.append(
                    Event(
                        Flag.ACCELERATION_EXCEEDED,
                        worst,
                        f"acceleration limit exceeded by {worst:.3g} to keep the position limit",
                    )
                )
        out = fixed
    return SafetyOutcome(out, tuple(events))
