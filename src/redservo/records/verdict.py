"""The success verdict of a run in words: what every place that shows an outcome prints.

A run's ``outcome`` says how it ended (``converged``, ``joint_limit``, ...); only the success
verdict says whether it was safe (:mod:`redservo.records.summary`, docs/safety.md): a run the
shield had to rescue ends ``converged`` and is no success. :func:`verdict` gives the words
(``"success"``, or ``"no success: "`` and why not), :func:`outcome_text` the outcome followed
by them; the console lines, ``compare.md``, the viewer's panel, ``animate``'s title and the
examples all call them, so they never disagree.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["failure_reasons", "outcome_text", "verdict"]

_ENDINGS = {
    "max_iterations": "iteration cap reached ({iterations} iterations) before convergence",
    "target_lost": "target lost (left the image)",
    "occluded": "target occluded",
    "feature_lost": "a feature was lost",
}
_MARGIN_ATOL = 1e-9  # as redservo.records.summary: a joint parked on the margin has met it


def _limit_text(summary: Mapping[str, Any], joints: Sequence[str]) -> str:
    hit = summary.get("limit_hit")
    if not hit:
        return "a joint limit was hit"
    j = int(hit["axis"])
    label = f" {joints[j]!r}" if j < len(joints) else ""
    return f"joint {j}{label} hit its limit at iteration {hit['iteration']}"


def failure_reasons(summary: Mapping[str, Any], joints: Sequence[str] = ()) -> list[str]:
    """Why a run is no success, one short phrase per reason (empty for a success).

    Args:
        summary: A :class:`~redservo.records.RunSummary` or its ``summary.json`` dict.
        joints: Joint names, to name the joint of a limit hit (indices are 0-based).
    """
    if summary.get("success"):
        return []
    out: list[str] = []
    outcome = str(summary.get("outcome", ""))
    hit = summary.get("collision")
    if outcome == "joint_limit":
        out.append(_limit_text(summary, joints))
    elif outcome == "collision" and hit:
        out.append(
            f"{hit['pair']} collided at iteration {hit['iteration']} "
            f"({-float(hit['distance']) * 1000:.2f} mm deep)"
        )
    elif outcome in _ENDINGS:
        out.append(_ENDINGS[outcome].format(iterations=summary.get("iterations", "?")))
    elif outcome != "converged":
        out.append(f"ended {outcome or 'without an outcome'}")
    shield = int(summary.get("shield_activations") or 0)
    if shield:
        out.append(f"the shield acted at {shield} step(s)")
    margin, required = summary.get("min_margin"), summary.get("min_margin_required")
    if margin is not None and required is not None and margin < required - _MARGIN_ATOL:
        out.append(f"min margin {margin:.4f} below the success margin {required:.4f}")
    for key, what in (
        ("velocity_violations", "velocity"),
        ("acceleration_violations", "acceleration"),
    ):
        if summary.get(key):
            out.append(f"{what} limit exceeded at {summary[key]} step(s)")
    return out or ["not safe (the summary does not say why)"]


def verdict(summary: Mapping[str, Any], joints: Sequence[str] = ()) -> str:
    """``"success"``, or ``"no success: "`` followed by :func:`failure_reasons` (``"; "``).

    A summary written before the success was recorded (no ``success`` key) gives
    ``"success not recorded"``: the verdict is never guessed from the outcome.
    """
    if "success" not in summary:
        return "success not recorded"
    if summary["success"]:
        return "success"
    return "no success: " + "; ".join(failure_reasons(summary, joints))


def outcome_text(summary: Mapping[str, Any], joints: Sequence[str] = ()) -> str:
    """The outcome and the verdict, e.g. ``"converged — no success: the shield acted at 3
    step(s)"``: what every place that shows a run's outcome prints."""
    return f"{summary.get('outcome', '?')} — {verdict(summary, joints)}"
