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
   ``q_safe = q̄ ∓ margin``, tightened by the braking bound when acceleration limits are
   known: ``√(h² + 2 q̈_max (d - q̈_max dt²/8)) - h`` with ``h = q̈_max dt / 2``, the
   discrete-time form of ``√(2 q̈_max d)``: commanding ``v``, then ``v - q̈_max dt``, ...
   down to zero travels at most ``v²/(2 q̈_max) + v dt/2 + q̈_max dt²/8`` (the last term
   bounds the rounding of the number of periods), so the joint can still stop before its
   safe limit, period after period, without breaking the acceleration limit.
   The command is clamped per joint into ``P ∩ R`` (the smallest change); then every
   joint is moved by whole float64 steps until ``q + dt·q̇`` lies within
   ``[q_safe_min, q_safe_max]`` *exactly* as the robot computes it. A joint that
   already lies in the margin band may not move further out, and returns at most at
   its velocity limit.

Priorities when the boxes conflict: the velocity limit, then the position shield, then
the acceleration limit (its excess is reported as ``ACCELERATION_EXCEEDED``). With the
shield off nothing outranks the rate limits. Either way, a command that takes a joint past
its *hard* limit (``q + dt q̇`` outside ``[q̄_min, q̄_max]``) although no command within the
limits that outrank the position could have kept it inside (a previous command too fast to
stop within ``q̈_max dt``, with the shield off) is reported as
``POSITION_LIMIT_UNAVOIDABLE``, naming the joint, with the distance past the limit. A
crossing some command could have avoided is the law's own choice (the shield being off)
and is not flagged; ``sns`` and ``qp`` never make it.

Everything here works on plain float64 arrays (n,); units rad/s (m/s), rad/s² (m/s²), s. The
numbers are computed by the kernels of :mod:`redservo.kernels.safety`; this module wraps them
and turns their flags into typed events.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from redservo._validation import FloatArray
from redservo.kernels import lazy
from redservo.kernels.flagbits import POSITION_LIMIT_UNAVOIDABLE
from redservo.limits import JointLimits
from redservo.redundancy.flags import Event
from redservo.redundancy.messages import events
from redservo.redundancy.packs import limits_pack

__all__ = [
    "SafetyOutcome",
    "apply_safety",
    "command_box",
    "exact_position_fix",
    "intersect_boxes",
    "position_box",
    "prev_command",
    "rate_box",
    "safety_events",
    "scale_into_box",
]

_TOL = 1e-12
"""Relative slack below which a command counts as inside a box (roundoff)."""

if TYPE_CHECKING:  # the kernel modules, typed; imported on first use at run time
    from redservo.kernels import events as _KE
    from redservo.kernels import safety as _K
else:
    _K = lazy("safety")
    _KE = lazy("events")


def prev_command(qdot_prev: FloatArray | None, n: int) -> tuple[FloatArray, bool]:
    """The previous command as the kernels take it: an array and a flag."""
    if qdot_prev is None:
        return _zeros(n), False
    return np.ascontiguousarray(qdot_prev, dtype=np.float64), True


def _zeros(n: int) -> FloatArray:
    z = _ZEROS.get(n)
    if z is None:
        z = np.zeros(n)
        _ZEROS[n] = z
    return z


_ZEROS: dict[int, FloatArray] = {}


def rate_box(
    limits: JointLimits, dt: float, qdot_prev: FloatArray | None
) -> tuple[FloatArray, FloatArray, bool]:
    """Return ``(lo, hi, accel_dropped)``: the rate box R (module docstring).

    The acceleration part is dropped (``accel_dropped``) on the joints where it does not
    meet the velocity box (a previous command above the velocity limit).
    """
    lp = limits_pack(limits)
    prev, has_prev = prev_command(qdot_prev, limits.n)
    lo, hi, dropped = _K.rate_box(lp.rows, lp.has_v, lp.has_a, float(dt), prev, has_prev)
    return lo, hi, bool(dropped)


def position_box(q: FloatArray, limits: JointLimits, dt: float) -> tuple[FloatArray, FloatArray]:
    """Return ``(lo, hi)``, the shield's box P of velocities keeping ``q + dt q̇`` safe."""
    lp = limits_pack(limits)
    qa = np.ascontiguousarray(q, dtype=np.float64)
    lo, hi = _K.position_box(qa, lp.rows, lp.has_v, lp.has_a, float(dt))
    return lo, hi


def command_box(
    q: FloatArray,
    limits: JointLimits,
    dt: float,
    qdot_prev: FloatArray | None,
    *,
    shield: bool = True,
) -> tuple[FloatArray, FloatArray]:
    """Return ``P ∩ R`` with the module's priorities (velocity, position, acceleration).

    This is the feasible set ``sns`` and ``qp`` optimize over, so that they satisfy the
    shield without it. Where P and R miss, the edge of P nearest to R (``shield``: the
    position wins), or without the shield that edge brought into R (the edge of R nearest
    to P): the rate stage, which always runs, would move the command there anyway, so the
    law plans with the velocity the joint will get (the smallest crossing;
    ``POSITION_LIMIT_UNAVOIDABLE``).
    """
    lp = limits_pack(limits)
    qa = np.ascontiguousarray(q, dtype=np.float64)
    prev, has_prev = prev_command(qdot_prev, limits.n)
    lo, hi = _K.command_box(
        qa, lp.rows, lp.has_v, lp.has_a, float(dt), prev, has_prev, bool(shield)
    )
    return lo, hi


def intersect_boxes(
    lo: FloatArray, hi: FloatArray, lo2: FloatArray, hi2: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Intersect a law's own box with :func:`command_box`; where they do not meet, the
    command box (the limits' priorities) wins."""
    c = np.ascontiguousarray
    nlo, nhi = _K.intersect_boxes(c(lo, float), c(hi, float), c(lo2, float), c(hi2, float))
    return nlo, nhi


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
    c = np.ascontiguousarray
    x = c(qdot, dtype=np.float64)
    t = _zeros(x.shape[0]) if task is None else c(task, dtype=np.float64)
    out, s = _K.scale_into_box(x, c(lo, float), c(hi, float), t, task is not None)
    return out, float(s)


def exact_position_fix(
    q: FloatArray, qdot: FloatArray, dt: float, limits: JointLimits
) -> FloatArray:
    """Move ``qdot`` by whole float64 steps until ``q + dt·q̇`` is within the safe limits.

    The target is ``[min(q_safe_min, q), max(q_safe_max, q)]``: a joint in the margin band
    may stay where it is. A few ``nextafter`` steps suffice (the box was already exact up
    to roundoff). Returns ``qdot`` itself when nothing had to move.
    """
    lp = limits_pack(limits)
    c = np.ascontiguousarray
    out, changed = _K.exact_position_fix(c(q, float), c(qdot, float), float(dt), lp.rows)
    return out if changed else qdot


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
    lp = limits_pack(limits)
    n = limits.n
    prev, has_prev = prev_command(qdot_prev, n)
    c = np.ascontiguousarray
    qa = c(q, dtype=np.float64)
    out, joint, worst, mask, vals, src = _KE.safety_with_events(
        c(qdot, dtype=np.float64),
        qa,
        lp.rows,
        lp.has_v,
        lp.has_a,
        float(dt),
        prev,
        has_prev,
        bool(shield),
        _zeros(n) if task is None else c(task, dtype=np.float64),
        task is not None,
    )
    if not mask:
        return SafetyOutcome(out, ())
    return SafetyOutcome(out, safety_events(mask, vals, src, qa, out, dt, limits, worst, joint))


def safety_events(
    mask: int,
    vals: FloatArray,
    src: NDArray[np.int64],
    q: FloatArray,
    qdot: FloatArray,
    dt: float,
    limits: JointLimits,
    worst: float,
    joint: int,
) -> tuple[Event, ...]:
    """The events of the safety kernel's ``(mask, vals, src)`` (its command ``qdot``, the
    acceleration excess ``worst`` and the joint ``joint`` past its hard limit)."""
    if not mask & _UNAVOIDABLE:  # the other messages name at most the excess
        return events(mask, vals, src, worst=worst)
    return events(mask, vals, src, **_context(q, qdot, dt, limits, worst, joint))


_UNAVOIDABLE = 1 << POSITION_LIMIT_UNAVOIDABLE


def _context(
    q: FloatArray, qdot: FloatArray, dt: float, limits: JointLimits, worst: float, joint: int
) -> dict[str, object]:
    """The numbers the safety messages name: the acceleration excess, and the joint
    ``joint`` that passes its hard limit (the kernel's
    :func:`~redservo.kernels.safety.unavoidable_crossing`), its side and ``q + dt q̇``."""

    def nxt() -> float:
        return float(q[joint] + dt * qdot[joint])

    def upper() -> bool:
        return nxt() > limits.q_max[joint]

    return {
        "worst": worst,
        "joint": joint,
        "nxt": nxt,
        "side": lambda: "upper" if upper() else "lower",
        "bound": lambda: float(limits.q_max[joint] if upper() else limits.q_min[joint]),
    }
