"""Which law to try when a run needed the shield or hit a limit (docs/choosing-a-law.md).

The advice rests on two things the project documents, not on a list of robots:

* how each law keeps the joints off their limits (:data:`APPROACHES`, the laws' docstrings
  and docs/formulas.md): a law with another approach takes another path to the goal;
* how often each law needed the position shield in the four Monte Carlo campaigns of
  docs/results.md (:data:`SHIELD_RUNS`; ``tests/test_advice.py`` recomputes them from that
  page, so the numbers here are the page's).

:func:`alternatives` keeps, for every approach other than the run's own, the law(s) of that
approach that needed the shield least often in the campaigns, when that is less often than
the run's law did (or never, as for the laws whose campaigns never needed it). :func:`law_hint` words it as one line with the ``redservo compare``
command that runs them.
"""

from __future__ import annotations

import shlex
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = [
    "APPROACHES",
    "SHIELD_RUNS",
    "alternatives",
    "compare_hint",
    "failed_at_a_limit",
    "law_hint",
]

APPROACHES: dict[str, str] = {
    "classical": "none",
    "gpm": "a gradient in the null space",
    "gpm-auto": "a gradient in the null space",
    "large-projection": "a gradient in the null space",
    "iterative-basic": "stopping the critical axes in the null space",
    "iterative": "stopping the critical axes in the null space",
    "iterative-smooth": "stopping the critical axes in the null space",
    "iterative-smooth-e2": "stopping the critical axes in the null space",
    "directional": "secondary motion only where it helps the task",
    "wln": "a weighted inverse that slows the joints near a limit",
    "sns": "hard joint bounds, the task scaled when infeasible",
    "qp": "hard joint bounds, the task scaled when infeasible",
    "qp-goal": "hard joint bounds and a joint goal, moved to when the task stalls",
    "predictive": "prediction of the limits over a horizon",
}
"""How each law keeps the joints off their limits (``none``: it does not)."""

SHIELD_RUNS: dict[str, tuple[int, int]] = {
    "classical": (527, 800),
    "gpm": (367, 800),
    "gpm-auto": (245, 800),
    "iterative-basic": (262, 800),
    "iterative": (229, 800),
    "iterative-smooth": (421, 800),
    "iterative-smooth-e2": (241, 800),
    "directional": (445, 800),
    "wln": (276, 800),
    "sns": (0, 800),
    "qp": (0, 800),
    "large-projection": (295, 800),
    "predictive": (0, 400),
    "qp-goal": (0, 400),
}
"""Per law, (runs in which the shield acted, runs) summed over the campaigns of
docs/results.md: panda-near-limits, cm01-gaze, mc05-joint-limits and cm01-humanoid-tracking,
200 runs each (``predictive`` and ``qp-goal``: the first and the third)."""


def _share(method: str) -> float:
    k, n = SHIELD_RUNS[method]
    return k / n


def failed_at_a_limit(summary: Mapping[str, Any]) -> bool:
    """Whether a run is no success because of the joint limits: the shield acted, a limit
    was hit, or the margin fell below the success margin."""
    if summary.get("success", True):
        return False
    margin, required = summary.get("min_margin"), summary.get("min_margin_required")
    low = margin is not None and required is not None and margin < required - 1e-9
    return bool(summary.get("shield_activations")) or summary.get("outcome") == "joint_limit" or low


def alternatives(method: str) -> list[str]:
    """The laws to try instead of ``method`` (module docstring), in ``redservo list`` order.

    A law without campaign numbers (registered by a user) is compared with every law."""
    from redservo.redundancy import METHODS

    own = APPROACHES.get(method)
    limit = _share(method) if method in SHIELD_RUNS else float("inf")
    best: dict[str, float] = {}
    for m in SHIELD_RUNS:
        approach = APPROACHES[m]
        if approach not in (own, "none"):
            best[approach] = min(best.get(approach, 1.0), _share(m))
    return [
        m
        for m in METHODS
        if m in SHIELD_RUNS
        and APPROACHES[m] in best
        and _share(m) == best[APPROACHES[m]]
        and (_share(m) < limit or _share(m) == 0.0)
    ]


def law_hint(
    summary: Mapping[str, Any],
    method: str,
    scenario: str,
    sets: Sequence[str] = (),
    *,
    reachable: bool | None = None,
) -> str | None:
    """One line for a run that failed at a limit (:func:`failed_at_a_limit`), else None.

    Args:
        summary: The run's summary.
        method: The law it ran.
        scenario: The scenario as the user named it (for the command to copy).
        sets: The ``--set`` assignments the run had (repeated in the command).
        reachable: Whether the goal is reachable within the success margin
            (:func:`redservo.campaign.reach.reachable`); None: not known.
    """
    if not failed_at_a_limit(summary):
        return None
    why = "needed the position shield" if summary.get("shield_activations") else "met a limit"
    if reachable is False:
        return (
            f"hint: {method} {why}, and no configuration with every joint inside the success "
            "margin reaches the goal (inverse-kinematics search): no law can succeed here; "
            "move the target or the desired pose, or start elsewhere (docs/choosing-a-law.md)"
        )
    others = alternatives(method)
    if not others:
        return (
            f"hint: {method} {why}; no law needed the shield less often in the campaigns "
            "(docs/choosing-a-law.md)"
        )
    shares = ", ".join(f"{m} ({100 * _share(m):.0f} %)" for m in others)
    goal = "the goal is reachable within the margin; " if reachable else ""
    command = ["redservo", "compare", scenario, "--methods", ",".join([method, *others])]
    for s in sets:
        command += ["--set", s]
    return (
        f"hint: {method} {why}; {goal}laws that keep off the limits another way, and needed "
        f"the shield in fewer campaign runs (docs/results.md): {shares}; try them: "
        f"{shlex.join(command)} (docs/choosing-a-law.md)"
    )


def compare_hint(
    summaries: Mapping[str, Mapping[str, Any]],
    scenario: str,
    sets: Sequence[str] = (),
    *,
    reachable: bool | None = None,
) -> str | None:
    """One line after ``redservo compare`` when some of its runs failed at a limit: the
    :func:`alternatives` of those laws that were not compared yet, with the command that adds
    them; None when no run failed so, or every alternative was compared already."""
    failed = [m for m, s in summaries.items() if failed_at_a_limit(s)]
    if not failed:
        return None
    if reachable is False:
        return (
            f"hint: {', '.join(failed)} failed at a limit, and no configuration with every joint "
            "inside the success margin reaches the goal (inverse-kinematics search): no law can "
            "succeed here; move the target or the desired pose, or start elsewhere "
            "(docs/choosing-a-law.md)"
        )
    new = [m for m in _in_order({o for m in failed for o in alternatives(m)}) if m not in summaries]
    if not new:
        return None
    command = ["redservo", "compare", scenario, "--methods", ",".join([*summaries, *new])]
    for s in sets:
        command += ["--set", s]
    return (
        f"hint: {', '.join(failed)} failed at a limit; laws not compared here that keep off the "
        f"limits another way and needed the shield in fewer campaign runs (docs/results.md): "
        f"{', '.join(new)}; try them: {shlex.join(command)} (docs/choosing-a-law.md)"
    )


def _in_order(names: set[str]) -> list[str]:
    from redservo.redundancy import METHODS

    return [m for m in METHODS if m in names]
