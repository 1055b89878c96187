"""The one table of flag messages: kernel event masks become :class:`Event` records.

Whether a flag is raised, and its number, are decided by the kernels of
:mod:`redservo.kernels.events` (the only copy of the flag rules). This module only words
them: :data:`MESSAGES` maps each (flag, source) to a template, filled with the flag's
value ``v`` and the numbers a law passes as ``ctx`` (the rank, ``m``, the condition
number...). A flag raised for several reasons in one call is one event whose message
joins the reasons' messages with ``"; "``.
"""

from __future__ import annotations

import string
from typing import Any

import numpy as np

from redservo.kernels import flagbits as fb
from redservo.redundancy.flags import FLAGS, Event, Flag

__all__ = ["MESSAGES", "events"]

_RANK = "J1 rank-deficient (rank {rank} < m = {m}): truncated pseudo-inverse"
_DAMPED = (
    "J1 ill-conditioned (σ_max/σ_min = {cond:.3g}): {filtered} direction(s) filtered, "
    "amplification bounded by {inv_robust:.3g}"
)

MESSAGES: dict[Flag, dict[int, str]] = {
    Flag.RANK_LOSS: {
        fb.BY_TASK: _RANK,
        fb.BY_DIRECTIONAL: "J1 rank {rank} < m = {m}: {v:g} task direction(s) uncontrolled; "
        "sub-threshold singular directions treated as free",
    },
    Flag.NO_REDUNDANCY: {
        fb.NORED_TASK: "no redundancy (rank J1 = n): reduces to the classical law",
        fb.NORED_WLN: "no redundancy (rank J1 = n): W has no effect on a full-rank square J1",
    },
    Flag.ILL_CONDITIONED: {
        fb.ILL_ROBUST: "ill-conditioned constraints: smallest singular value {min_sigma:.2g}, "
        "null-space motion amplified up to {v:.3g}x (filtered: robust inverse)",
        fb.ILL_EXACT: "ill-conditioned constraints: smallest singular value {min_sigma:.2g}, "
        "null-space motion amplified up to {v:.3g}x (raise constraint_rcond to cap it)",
    },
    Flag.DAMPED: {
        fb.DAMPED_TASK: _DAMPED,
        fb.DAMPED_ALPHA: "axis {axis}: |(J1^⊥ e2)_k| = {den:.3g} small, eq. 9 filtered "
        "(amplification bounded by {inv_alpha_filter:.3g})",
        fb.DAMPED_CONSTRAINTS: "constraint rows filtered below σ = {con_filter:g} "
        "(amplification bounded by {inv_con_filter:.3g} per level)",
        fb.DAMPED_PII: "joint-limit term: |P_ii| < {pf:g} on {n_pf} axis(es), 1/|P_ii| "
        "filtered (b_i bounded by {inv_pf:.3g} |q̇1_i|)",
        fb.DAMPED_WEIGHTED: "J1 ill-conditioned (σ_max/σ_min = {wcond:.3g}): {wfiltered} "
        "direction(s) filtered, amplification bounded by {inv_robust:.3g}",
    },
    Flag.OVERCONSTRAINED: {
        fb.ONLY: "{n_con} constrained axes > n_a = {n_a}: least-squares, not all met",
    },
    Flag.LEAST_SQUARES: {
        fb.LS_LEVELS: "constraints met only in the least-squares sense at levels {unmet}",
        fb.LS_WEIGHTED: "weighted task rank {wrank} < rank J1 = {rank} (joints blocked at a "
        "limit: {blocked}): task tracked in the least-squares sense",
    },
    Flag.AXES_NOT_HANDLED: {
        fb.ONLY: "critical axes {others} not handled (gpm-auto stops one axis)",
    },
    Flag.GAIN_ADJUSTED: {
        fb.GAIN_UNDEFINED: "axis {axis} critical but (J1^⊥ e2)_k ≈ 0: α undefined, set to 0",
        fb.GAIN_NEGATIVE: "axis {axis}: eq. 9 gives α = {alpha_raw:.3g} < 0, set to 0",
        fb.GAIN_CAPPED: "α = {alpha_raw:.3g} capped to alpha_max = {v:.3g}",
    },
    Flag.TASK_SCALED: {
        fb.SCALED_SNS: "task scaled by s = {v:.6g}",
        fb.SCALED_SNS_RESTORED: "task scaled by s = {v:.6g} (saturations exhausted the "
        "redundancy: best s* restored)",
        fb.SCALED_QP: "bounds prevent the task: relative task residual {v:.3g}",
    },
    Flag.SOLVER_FALLBACK: {fb.ONLY: "solver: {solver}"},
    Flag.BOUNDS_CONFLICT: {
        fb.ONLY: "joints {conflicts}: push-back toward the allowed band exceeds v_max; "
        "velocity fixed at ±v_max",
    },
    Flag.NO_SECONDARY: {fb.ONLY: "no secondary command (z = 0)"},
    Flag.VELOCITY_SCALED: {fb.ONLY: "command scaled by {v:.3g} into the rate limits"},
    Flag.ACCELERATION_LIMITED: {fb.ONLY: "command scaled by {v:.3g} into the rate limits"},
    Flag.ACCELERATION_EXCEEDED: {
        fb.ACC_RELEASED: "acceleration limit released on some joints (it conflicted with the "
        "velocity or position limits, which win)",
        fb.ACC_KEPT_POSITION: "acceleration limit exceeded by {worst:.3g} to keep the position "
        "limit",
    },
    Flag.SHIELD_ACTED: {fb.ONLY: "position shield changed q̇ by {v:.3g}"},
    Flag.NON_FINITE_REPLACED: {fb.ONLY: "{v:g} non-finite entries: command replaced"},
    Flag.POSITION_LIMIT_UNAVOIDABLE: {
        fb.ONLY: "joint {joint} passes its {side} limit {bound:.6g} by {v:.6g} (q + dt q̇ = "
        "{nxt:.9g}): no command within the rate limits stops it in time (previous command "
        "too fast for q̈_max dt, or the velocity limit)",
    },
    Flag.HORIZON_INFEASIBLE: {
        fb.ONLY: "no command sequence over the {horizon}-period horizon meets the constraints "
        "(daqp exit {v:g}): {fallback} command used",
    },
    Flag.SOLVER_ITERATIONS: {
        fb.BY_ITERATIONS: "QP solver stopped at its iteration limit ({v:g} iterations): "
        "{fallback} command used",
        fb.BY_TIME_BUDGET: "solve took {v:.3g} s, over the time budget: {fallback} command used",
    },
    Flag.CAMERA_MOTION_LIMITED: {
        fb.ONLY: "command scaled by {v:.3g}: the fastest image point would move {motion_px:.3g} px "
        "between two frames (limit {limit_px:.3g} px)",
    },
    Flag.DISTANCE_SHIELD: {fb.ONLY: "distance shield scaled q̇ by {v:.3g}"},
    Flag.NO_POSE: {
        fb.POSE_FEW_DOTS: "no PnP pose of the target: {dots} finite tracked dot(s) for its "
        "{points} point(s) ({v:g} frame(s) in a row); the model's pose is the features'",
        fb.POSE_REJECTED: "no PnP pose of the target's {dots} tracked dots within the "
        "reprojection tolerance ({v:g} frame(s) in a row); the model's pose is the features'",
        fb.SENSOR_FEW_DOTS: "image sensor: no PnP pose of {target!r}: {dots} detected dot(s) of "
        "its {points}, at least 4 needed ({v:g} frame(s) in a row); its terms' interaction "
        "matrices keep the depths of the last pose (the desired depths before the first)",
        fb.SENSOR_REJECTED: "image sensor: no PnP pose of {target!r} from its {dots} detected "
        "dot(s) within the reprojection tolerance ({v:g} frame(s) in a row); its terms' "
        "interaction matrices keep the depths of the last pose (the desired depths before the "
        "first)",
    },
}
"""Per flag, per source bit (:mod:`redservo.kernels.flagbits`), the message template."""


_FIELDS: dict[str, tuple[str, ...]] = {
    t: tuple({f for _, f, _, _ in string.Formatter().parse(t) if f and f != "v"})
    for table in MESSAGES.values()
    for t in table.values()
}
"""The names each template uses besides ``v``."""


_PLANS: dict[tuple[int, int], tuple[Flag, tuple[tuple[str, tuple[str, ...]], ...]]] = {}
"""Per (flag bit, source bits): the flag and the templates to fill with their names."""


def _plan(j: int, why: int) -> tuple[Flag, tuple[tuple[str, tuple[str, ...]], ...]]:
    flag = FLAGS[j]
    plan = (flag, tuple((t, _FIELDS[t]) for bit, t in MESSAGES[flag].items() if why & bit))
    _PLANS[(j, why)] = plan
    return plan


def events(mask: int, vals: np.ndarray, src: np.ndarray, **ctx: Any) -> tuple[Event, ...]:
    """The :class:`Event` of each flag of a kernel's ``(mask, vals, src)``, in flag order.

    ``ctx`` holds the numbers the templates of the raised flags name (a law passes what its
    messages need, a costly one as a function called only if a message names it; ``v`` is
    the flag's value).
    """
    out = []
    while mask:
        j = (mask & -mask).bit_length() - 1
        mask &= mask - 1
        value = float(vals[j])
        why = int(src[j])
        flag, templates = _PLANS.get((j, why)) or _plan(j, why)
        texts = []
        for template, fields in templates:
            if not fields:
                texts.append(template.format(v=value))
                continue
            names = {}
            for name in fields:
                item = ctx[name]
                if callable(item):
                    item = ctx[name] = item()
                names[name] = item
            texts.append(template.format(v=value, **names))
        out.append(Event(flag, value, texts[0] if len(texts) == 1 else "; ".join(texts)))
    return tuple(out)
