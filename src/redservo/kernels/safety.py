"""Kernels of the safety layer: rate box, position box, scaling and the exact shield.

The formulas and priorities are those of :mod:`redservo.redundancy.safety` (which wraps
these kernels and documents them; docs/safety.md). ``lp`` is the (11, n) packed limits
of :func:`redservo.kernels.pack.limits_pack`; ``has_v``/``has_a`` say whether velocity
and acceleration limits exist; ``prev``/``has_prev`` carry the previous command.
Units: rad (m), rad/s (m/s), rad/s² (m/s²), s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.kernels._jit import kernel
from redservo.kernels.pack import AMAX, Q_MAX, Q_MIN, SAFE_MAX, SAFE_MIN, VMAX

__all__ = [
    "apply_safety",
    "command_box",
    "exact_position_fix",
    "intersect_boxes",
    "position_box",
    "rate_box",
    "scale_into_box",
    "unavoidable_crossing",
]

TOL = 1e-12
"""Relative slack below which a command counts as inside a box (roundoff)."""


@kernel
def rate_box(lp: Any, has_v: bool, has_a: bool, dt: float, prev: Any, has_prev: bool) -> Any:
    """``(lo, hi, dropped)``: velocity box ∩ acceleration box (the latter dropped per joint
    where it misses the velocity box)."""
    n = lp.shape[1]
    lo = np.empty(n)
    hi = np.empty(n)
    dropped = False
    for i in range(n):
        if has_v:
            lo[i] = -lp[VMAX, i]
            hi[i] = lp[VMAX, i]
        else:
            lo[i] = -np.inf
            hi[i] = np.inf
        if has_a and has_prev:
            alo = prev[i] - lp[AMAX, i] * dt
            ahi = prev[i] + lp[AMAX, i] * dt
            nlo = max(lo[i], alo)
            nhi = min(hi[i], ahi)
            if nlo <= nhi:
                lo[i] = nlo
                hi[i] = nhi
            else:
                dropped = True
    return lo, hi, dropped


@kernel
def position_box(q: Any, lp: Any, has_v: bool, has_a: bool, dt: float) -> Any:
    """``(lo, hi)``: the velocities keeping ``q + dt q̇`` within the safe limits, with the
    braking bound and the retreat from the margin band at most at the velocity limit."""
    n = q.shape[0]
    lo = np.empty(n)
    hi = np.empty(n)
    for i in range(n):
        d_hi = lp[SAFE_MAX, i] - q[i]
        d_lo = q[i] - lp[SAFE_MIN, i]
        h = d_hi / dt
        low = -d_lo / dt
        if has_a:  # braking bound in discrete time (redundancy/safety.py, docs/safety.md)
            a = lp[AMAX, i]
            half = 0.5 * a * dt
            slack = 0.125 * a * dt * dt
            h = min(h, np.sqrt(half * half + 2.0 * a * max(d_hi - slack, 0.0)) - half)
            low = max(low, half - np.sqrt(half * half + 2.0 * a * max(d_lo - slack, 0.0)))
        back = -lp[VMAX, i] if has_v else 0.0
        if d_hi < 0.0:
            h = max(h, back)
        if d_lo < 0.0:
            low = min(low, -back)
        lo[i] = low
        hi[i] = h
    return lo, hi


@kernel
def command_box(
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    dt: float,
    prev: Any,
    has_prev: bool,
    shield: bool = True,
) -> Any:
    """``P ∩ R``. Where they miss, with ``shield`` the position wins and the acceleration is
    broken as little as possible (the box is the edge of P nearest to R); without it the
    rate box wins, as it does in :func:`apply_safety`: that edge brought into R (the edge
    of R nearest to P, so the joint crosses by as little as the rate limits allow; when P
    itself is empty, a joint in its margin band too close to its other limit to brake, the
    shield's choice if R holds it)."""
    rlo, rhi, _ = rate_box(lp, has_v, has_a, dt, prev, has_prev)
    plo, phi = position_box(q, lp, has_v, has_a, dt)
    n = q.shape[0]
    lo = np.empty(n)
    hi = np.empty(n)
    for i in range(n):
        lo[i] = max(rlo[i], plo[i])
        hi[i] = min(rhi[i], phi[i])
        if lo[i] > hi[i]:  # the position wins; the acceleration is broken as little as possible
            edge = plo[i] if rhi[i] < plo[i] else phi[i]
            if not shield:  # the rate limits win; the position is given up as little as possible
                edge = _clip(edge, rlo[i], rhi[i])
            lo[i] = edge
            hi[i] = edge
    return lo, hi


@kernel
def intersect_boxes(lo: Any, hi: Any, lo2: Any, hi2: Any) -> Any:
    """Intersect two boxes; where they do not meet, the second one wins."""
    n = lo.shape[0]
    nlo = np.empty(n)
    nhi = np.empty(n)
    for i in range(n):
        a = max(lo[i], lo2[i])
        b = min(hi[i], hi2[i])
        if a > b:
            a = lo2[i]
            b = hi2[i]
        nlo[i] = a
        nhi[i] = b
    return nlo, nhi


@kernel
def _inside(x: Any, lo: Any, hi: Any) -> bool:
    for i in range(x.shape[0]):
        slack = TOL * (1.0 + abs(x[i]))
        if not (x[i] >= lo[i] - slack and x[i] <= hi[i] + slack):
            return False
    return True


@kernel
def _clip(x: float, lo: float, hi: float) -> float:
    """``np.clip`` of one number: ``min(max(x, lo), hi)``."""
    return min(max(x, lo), hi)


@kernel
def _max_scale(base: Any, step: Any, lo: Any, hi: Any) -> float:
    """Largest ``s ∈ [0, 1]`` with ``lo <= base + s step <= hi`` (``base`` inside the box).

    A joint whose box is a single point (a braking joint pinned where its acceleration and
    position limits meet) does not limit ``s``: it takes its one allowed value anyway."""
    s = 1.0
    for i in range(base.shape[0]):
        if hi[i] - lo[i] <= TOL * (1.0 + abs(lo[i])):
            continue
        if step[i] > 0.0:
            s = min(s, (hi[i] - base[i]) / step[i])
        elif step[i] < 0.0:
            s = min(s, (lo[i] - base[i]) / step[i])
    return s if s > 0.0 else 0.0  # never -0.0 (a scale printed as "-0")


@kernel
def scale_into_box(qdot: Any, lo: Any, hi: Any, task: Any, has_task: bool) -> Any:
    """``(q̇, s)``: ``qdot`` scaled into the box keeping its direction (secondary-first when
    ``has_task``: the part beyond ``task`` first), then clipped (roundoff)."""
    n = qdot.shape[0]
    out = np.empty(n)
    if _inside(qdot, lo, hi):
        for i in range(n):
            out[i] = _clip(qdot[i], lo[i], hi[i])
        return out, 1.0
    anchor = np.empty(n)
    for i in range(n):
        anchor[i] = _clip(0.0, lo[i], hi[i])
    if has_task and _inside(task, lo, hi):
        t = np.empty(n)
        rest = np.empty(n)
        for i in range(n):
            t[i] = _clip(task[i], lo[i], hi[i])
            rest[i] = qdot[i] - task[i]
        s = _max_scale(t, rest, lo, hi)
        for i in range(n):
            out[i] = _clip(t[i] + s * rest[i], lo[i], hi[i])
        return out, s
    step = np.empty(n)
    for i in range(n):
        step[i] = (task[i] if has_task else qdot[i]) - anchor[i]
    s = _max_scale(anchor, step, lo, hi)
    for i in range(n):
        out[i] = _clip(anchor[i] + s * step[i], lo[i], hi[i])
    return out, s


@kernel
def exact_position_fix(q: Any, qdot: Any, dt: float, lp: Any) -> Any:
    """``(q̇, changed)``: each joint moved by whole float64 steps (at most 64) until
    ``q + dt q̇`` lies in ``[min(q_safe_min, q), max(q_safe_max, q)]``."""
    n = q.shape[0]
    out = qdot.copy()
    changed = False
    for i in range(n):
        top = max(lp[SAFE_MAX, i], q[i])
        bottom = min(lp[SAFE_MIN, i], q[i])
        v = qdot[i]
        for _ in range(64):
            nxt = q[i] + dt * v
            if nxt > top:
                v = np.nextafter(v, -np.inf)
            elif nxt < bottom:
                v = np.nextafter(v, np.inf)
            else:
                break
        if v != qdot[i]:
            out[i] = v
            changed = True
    return out, changed


@kernel
def unavoidable_crossing(
    q: Any,
    qdot: Any,
    dt: float,
    lp: Any,
    has_v: bool,
    has_a: bool,
    prev: Any,
    has_prev: bool,
    shield: bool,
) -> Any:
    """``(distance, joint)``: the largest distance past a hard limit of ``q + dt q̇`` (as
    float64 computes it) over the joints that no command could have kept inside, and that
    joint (``0.0, -1`` if none).

    A joint counts when ``q + dt q̇`` lies outside ``[min(q̄_min, q), max(q̄_max, q)]`` (a
    joint already beyond its limit by the validation tolerance may stay) *and* so does
    ``q + dt v`` for the velocity ``v`` nearest the limit's inside within the limits that
    outrank the position: the velocity box with the shield on; the rate box (velocity and
    acceleration, as :func:`rate_box` forms it) with the shield off.
    """
    if shield:
        rlo = np.empty(q.shape[0])
        rhi = np.empty(q.shape[0])
        for i in range(q.shape[0]):
            rlo[i] = -lp[VMAX, i] if has_v else -np.inf
            rhi[i] = lp[VMAX, i] if has_v else np.inf
    else:
        rlo, rhi, _ = rate_box(lp, has_v, has_a, dt, prev, has_prev)
    worst = 0.0
    joint = -1
    for i in range(q.shape[0]):
        top = max(lp[Q_MAX, i], q[i])
        bottom = min(lp[Q_MIN, i], q[i])
        nxt = q[i] + dt * qdot[i]
        past = 0.0
        if nxt > top and q[i] + dt * rlo[i] > top:
            past = nxt - top
        elif nxt < bottom and q[i] + dt * rhi[i] < bottom:
            past = bottom - nxt
        if past > worst:
            worst = past
            joint = i
    return worst, joint


@kernel
def _shield_stage(
    out: Any,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    dt: float,
    prev: Any,
    has_prev: bool,
    dropped: bool,
) -> Any:
    """The shield on the rate stage's command: ``(q̇, change, acted, accel_excess,
    accel_exceeded)`` (:func:`apply_safety`)."""
    n = q.shape[0]
    plo, phi = command_box(q, lp, has_v, has_a, dt, prev, has_prev)
    clamped = np.empty(n)
    for i in range(n):
        clamped[i] = _clip(out[i], plo[i], phi[i])
    fixed, _ = exact_position_fix(q, clamped, dt, lp)
    change = 0.0
    big = 0.0
    for i in range(n):
        change = max(change, abs(fixed[i] - out[i]))
        big = max(big, abs(out[i]))
    acted = change > TOL * (1.0 + big)
    worst = np.nan
    exceeded = False
    if has_prev and has_a:
        worst = -np.inf
        amax = 0.0
        for i in range(n):
            worst = max(worst, abs(fixed[i] - prev[i]) - lp[AMAX, i] * dt)
            amax = max(amax, lp[AMAX, i])
        worst = worst / dt
        exceeded = worst > TOL * (1.0 + amax) and not dropped
    return fixed, change, acted, worst, exceeded


@kernel
def apply_safety(
    qdot: Any,
    q: Any,
    lp: Any,
    has_v: bool,
    has_a: bool,
    dt: float,
    prev: Any,
    has_prev: bool,
    shield: bool,
    task: Any,
    has_task: bool,
) -> Any:
    """The rate stage and the shield on a raw command (redundancy/safety.py).

    Returns:
        ``(q̇, non_finite, s, over_v, dropped, change, shield_acted, accel_excess,
        accel_exceeded, past_limit, past_joint)``: the safe command, the number of
        non-finite entries replaced (then q̇ = 0), the rate scale s, whether the raw command
        exceeded the velocity limit, whether the acceleration limit was released on some
        joint, the largest change made by the shield and whether it counts, the largest
        acceleration excess (rad/s²) and whether it is reported, and
        :func:`unavoidable_crossing` of the safe command (distance > 0: the position limit
        was given up on ``past_joint``).
    """
    n = q.shape[0]
    bad = 0
    for i in range(n):
        if not np.isfinite(qdot[i]):
            bad += 1
    cmd = qdot
    use_task = has_task
    if bad:
        cmd = np.zeros(n)
        use_task = False
    if use_task:
        for i in range(n):
            if not np.isfinite(task[i]):
                use_task = False
    rlo, rhi, dropped = rate_box(lp, has_v, has_a, dt, prev, has_prev)
    if shield:  # where the acceleration box misses the position box, the position wins
        plo, phi = position_box(q, lp, has_v, has_a, dt)
        for i in range(n):
            if max(rlo[i], plo[i]) > min(rhi[i], phi[i]):
                # the position wins; the acceleration is broken as little as possible (this
                # also absorbs a one-ulp miss between the two boxes)
                edge = plo[i] if rhi[i] < plo[i] else phi[i]
                rlo[i] = edge
                rhi[i] = edge
                dropped = True
    out, s = scale_into_box(cmd, rlo, rhi, task, use_task)
    over_v = False
    if s < 1.0 and has_v:
        for i in range(n):
            if abs(cmd[i]) > lp[VMAX, i] * (1.0 + TOL):
                over_v = True
    change = 0.0
    acted = False
    worst = np.nan
    exceeded = False
    if shield:
        out, change, acted, worst, exceeded = _shield_stage(
            out, q, lp, has_v, has_a, dt, prev, has_prev, dropped
        )
    past, joint = unavoidable_crossing(q, out, dt, lp, has_v, has_a, prev, has_prev, shield)
    return out, bad, s, over_v, dropped, change, acted, worst, exceeded, past, joint
