"""The typed summary of a run, and what counts as a success (docs/safety.md).

A run is a **success** only if it converged with every joint at least ``min_margin``
(fraction of its range) from its hard limits all along, no command exceeded a velocity
or acceleration limit, and the position shield never had to act: a method that needed
the shield did not avoid the limit by itself, and no collision pair ever overlapped
(``min_distance < 0``). Joint indices are 0-based everywhere.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any, Literal, get_args

import numpy as np

from redservo.limits import JointLimits
from redservo.records.runlog import SimulationLog
from redservo.redundancy.flags import FLAGS, Flag

__all__ = [
    "OUTCOMES",
    "SUCCESS_MARGIN",
    "FlagCount",
    "Outcome",
    "RunSummary",
    "clear_of_limits",
    "flag_warnings",
    "run_succeeded",
    "summarize",
]

Outcome = Literal[
    "converged",
    "joint_limit",
    "max_iterations",
    "target_lost",
    "occluded",
    "feature_lost",
    "collision",
]
OUTCOMES: tuple[Outcome, ...] = get_args(Outcome)
SUCCESS_MARGIN = 0.01
"""Smallest distance of every joint to its real limits, fraction of the joint's range, for a run
to count as a success (and for a reproduction check to say "no joint limit reached")."""
_MARGIN_ATOL = 1e-9
"""A joint parked exactly on its margin (``sns``, ``qp``) has met it: the fraction computed back
from the position may differ from it by roundoff."""


def clear_of_limits(margin: float, required: float = SUCCESS_MARGIN) -> bool:
    """Whether a run's smallest margin (fraction of the range) meets ``required`` (a joint
    parked exactly on it, to roundoff, does)."""
    return bool(margin >= required - _MARGIN_ATOL)


def run_succeeded(
    outcome: str,
    margin: float,
    min_margin: float,
    v_viol: int,
    a_viol: int,
    shield: int,
    min_distance: float | None = None,
) -> bool:
    """A run's ``success``: converged, its smallest joint margin (fraction of the range)
    clear of ``min_margin`` (:func:`clear_of_limits`), no velocity or acceleration excess
    (steps), the position shield never acted (steps), and no collision pair overlapped
    (``min_distance``, m, None when not measured). The one rule of every path (the
    campaign loop's compiled summary, ``redservo.campaign.loop_summary``, too)."""
    return bool(
        _clear(min_distance)
        and outcome == "converged"
        and clear_of_limits(margin, min_margin)
        and v_viol == 0
        and a_viol == 0
        and shield == 0
    )


_ACCEL_RTOL = 1e-9
"""Relative slack on ``|Δq̇| <= q̈_max dt`` (the subtraction of two commands rounds)."""


@dataclass(frozen=True)
class FlagCount:
    """How often a flag was raised in a run, and first when (0-based iteration)."""

    count: int
    first: int


@dataclass(frozen=True)
class RunSummary(Mapping[str, Any]):
    """What happened in one run. Units: m, rad, s; joint indices 0-based.

    Mapping access (``summary["outcome"]``) is kept for the dictionary form of earlier
    versions; :meth:`to_dict` gives the JSON form written to ``summary.json``.
    """

    outcome: Outcome
    success: bool
    iterations: int
    final_error_norm: float
    limit_hit: dict[str, int] | None
    min_margin: float
    """Smallest distance of any joint to a hard limit, as a fraction of its range."""
    min_margin_required: float
    max_joint_speed: list[float]
    """Per joint, the largest |q̇| commanded (rad/s or m/s)."""
    peak_velocity_ratio: float | None
    """Largest |q̇_i| / q̇_max,i over the run: 0 for a run without a step, None only when the
    limits have no velocity limit."""
    velocity_violations: int
    """Steps where some |q̇_i| exceeded its velocity limit."""
    acceleration_violations: int
    """Steps where some |q̇_i - q̇_i,prev| exceeded q̈_max,i dt (the first from rest)."""
    shield_activations: int
    """Steps where the position shield changed the command."""
    max_camera_speed: dict[str, float]
    discontinuity: float
    flags: dict[str, FlagCount] = field(default_factory=dict)
    """For each flag raised: (count of steps, first iteration)."""
    min_distance: float | None = None
    """Smallest distance (m) between a link and an obstacle or another link over the run,
    the contact that ended a ``collision`` run included; None when none was measured."""
    closest_pair: str | None = None
    """The pair at :attr:`min_distance` (``"link/obstacle"`` or ``"link/link"``), or None."""
    collision: dict[str, Any] | None = None
    """``{"pair", "distance" (m, <= 0), "iteration"}`` of the contact that ended the run."""
    min_distance_by_kind: dict[str, float] | None = None
    """Smallest distance (m) per pair kind, ``"environment"`` (link/obstacle) and ``"self"``
    (link/link), over the steps measured; None when none was measured."""
    steps_within_influence: int | None = None
    """Steps in which some pair was closer than ``d_influence``; None when not measured."""
    min_manipulability: float | None = None
    """Smallest Yoshikawa measure ``sqrt(det(J1 J1ᵀ))`` of the task Jacobian over the run
    (:mod:`redservo.control.manipulability`); None when not measured."""
    min_singular_value: float | None = None
    """Smallest singular value of the task Jacobian over the run; None when not measured."""

    def __getitem__(self, key: str) -> Any:
        if key not in _FIELDS:
            raise KeyError(key)
        return self.to_dict()[key] if key == "flags" else getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(_FIELDS)

    def __len__(self) -> int:
        return len(_FIELDS)

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (``summary.json``)."""
        d = asdict(self)
        d["flags"] = {k: {"count": v.count, "first": v.first} for k, v in self.flags.items()}
        return d


_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(RunSummary))


def _rates(log: SimulationLog, limits: JointLimits, dt: float) -> tuple[float | None, int, int]:
    """Return (peak |q̇|/q̇_max, velocity-violation steps, acceleration-violation steps)."""
    qd = log.qdot
    ratio: float | None = None
    v_viol = a_viol = 0
    if limits.qdot_max is not None:  # never None when there are velocity limits
        ratio = float(np.max(np.abs(qd) / limits.qdot_max)) if len(log) else 0.0
        v_viol = int(np.count_nonzero(np.any(np.abs(qd) > limits.qdot_max, axis=1)))
    if limits.qddot_max is not None and len(log):
        dq = np.diff(np.vstack([np.zeros((1, qd.shape[1])), qd]), axis=0)
        bound = limits.qddot_max * dt * (1.0 + _ACCEL_RTOL) + 1e-15
        a_viol = int(np.count_nonzero(np.any(np.abs(dq) > bound, axis=1)))
    return ratio, v_viol, a_viol


def _flag_counts(log: SimulationLog) -> dict[str, FlagCount]:
    out: dict[str, FlagCount] = {}
    if log.flags is None or not len(log):
        return out
    raised = ~np.isnan(log.flags)
    counts, first = raised.sum(axis=0), raised.argmax(axis=0)  # per flag, in 3 calls, not 2F
    for j in np.flatnonzero(counts):
        out[FLAGS[j].label] = FlagCount(int(counts[j]), int(first[j]))
    return out


def summarize(
    log: SimulationLog,
    outcome: Outcome,
    limits: JointLimits,
    limit_hit: dict[str, int] | None,
    *,
    dt: float | None = None,
    min_margin: float = SUCCESS_MARGIN,
    collision: dict[str, Any] | None = None,
    distances: Mapping[str, Any] | None = None,
    singularity: Mapping[str, Any] | None = None,
) -> RunSummary:
    """Return the typed run summary (module docstring for ``success``).

    Args:
        log: The run's log.
        outcome: How it ended.
        limits: The limits the law was given (positions, rates).
        limit_hit: ``{"axis", "iteration"}`` (0-based) of a limit crossing, or None.
        dt: Control period (s) for the acceleration check (default: from ``log.t``).
        min_margin: Required margin for success, fraction of each range.
        collision: ``{"pair", "distance", "iteration"}`` of a contact that ended the run.
        distances: ``min_distance_by_kind`` and ``steps_within_influence``
            (:meth:`redservo.collision.tally.DistanceTally.fields`), or None.
        singularity: ``min_manipulability`` and ``min_singular_value``
            (:meth:`redservo.control.manipulability.SingularityMargin.fields`), or None.
    """
    n = limits.n
    if dt is None:
        dt = float(log.t[1] - log.t[0]) if len(log) > 1 else 1.0
    if len(log):
        margin = float(np.min(limits.margin(log.q)))
        max_joint = np.max(np.abs(log.qdot), axis=0)
        tw = log.camera_twist
        max_cam = {
            "translation": float(np.max(np.linalg.norm(tw[:, :3], axis=1))),
            "rotation": float(np.max(np.linalg.norm(tw[:, 3:], axis=1))),
        }
        jumps = np.linalg.norm(np.diff(log.qdot, axis=0), axis=1)
        disc = float(np.max(jumps)) if jumps.size else 0.0
        final = float(log.error_norm[-1])
    else:
        margin, max_joint, disc, final = float("nan"), np.zeros(n), 0.0, float("nan")
        max_cam = {"translation": 0.0, "rotation": 0.0}
    ratio, v_viol, a_viol = _rates(log, limits, dt)
    flags = _flag_counts(log)
    shield = flags[Flag.SHIELD_ACTED.label].count if Flag.SHIELD_ACTED.label in flags else 0
    extra = {**_closest(log, collision), **(distances or {}), **(singularity or {})}
    success = run_succeeded(
        outcome, margin, min_margin, v_viol, a_viol, shield, extra["min_distance"]
    )
    return RunSummary(
        outcome=outcome,
        success=bool(success),
        iterations=len(log),
        final_error_norm=final,
        limit_hit=limit_hit,
        min_margin=margin,
        min_margin_required=float(min_margin),
        max_joint_speed=[float(v) for v in max_joint],
        peak_velocity_ratio=ratio,
        velocity_violations=v_viol,
        acceleration_violations=a_viol,
        shield_activations=shield,
        max_camera_speed=max_cam,
        discontinuity=disc,
        flags=flags,
        collision=collision,
        **extra,
    )


def _clear(min_distance: float | None) -> bool:
    """No collision pair overlapped (``min_distance``, m, None when not measured)."""
    return min_distance is None or min_distance >= 0.0


def _closest(log: SimulationLog, hit: dict[str, Any] | None) -> dict[str, Any]:
    """``min_distance`` and ``closest_pair`` of the summary from the log and the contact."""
    d = log.min_distance
    best: tuple[float, str] | None = None
    if d is not None and log.closest_pair is not None and np.any(~np.isnan(d)):
        i = int(np.nanargmin(d))
        best = (float(d[i]), log.pair_names[int(log.closest_pair[i])])
    if hit is not None and (best is None or hit["distance"] < best[0]):
        best = (float(hit["distance"]), str(hit["pair"]))
    return {
        "min_distance": None if best is None else best[0],
        "closest_pair": None if best is None else best[1],
    }


def flag_warnings(summary: RunSummary | Mapping[str, Any]) -> list[str]:
    """One line per diagnostic flag raised in a run: label, count, first iteration (0-based)."""
    flags = summary.flags if isinstance(summary, RunSummary) else summary.get("flags", {})
    lines = []
    for flag in FLAGS:
        fc = flags.get(flag.label)
        if fc is None:
            continue
        count, first = (
            (fc.count, fc.first) if isinstance(fc, FlagCount) else (fc["count"], fc["first"])
        )
        lines.append(f"{flag.label}: {count} step(s), first at iteration {first}")
    return lines
