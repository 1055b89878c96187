"""The runs of the CM01 gaze experiment (§V-A1–3, Figs. 8–13) and the imperfect robot.

Labels, gains and the imperfect-robot model shared by the experiment's checks
(:mod:`~redservo.reproduction.cm01_gaze_checks`) and figures
(:mod:`~redservo.reproduction.cm01_gaze_figures`); the experiment itself is
:mod:`~redservo.reproduction.cm01_gaze`.
"""

from __future__ import annotations

from redservo.experiment.build import Experiment
from redservo.reproduction.base import RunSpec

__all__ = [
    "ALPHA_ENOUGH",
    "ALPHA_HUGE",
    "ALPHA_MODERATE",
    "ALPHA_SMALL",
    "AUTO",
    "AUTO_CURRENT",
    "GPM",
    "IMPERFECT_DELAY",
    "IMPERFECT_QDOT_MAX",
    "IMPERFECT_TAU",
    "ITERATIVE",
    "RUNS",
    "imperfect",
    "imperfect_robot",
]

ALPHA_SMALL = 0.25
"""A gain too small for gpm: a joint limit is hit (CM01: 1.5)."""
ALPHA_ENOUGH = 0.5
"""The smallest gain of our grid {0.25, 0.5, 1, 1.5, 2, 3, 5, ...} with which gpm succeeds."""
ALPHA_MODERATE = 2.0
"""CM01's moderate gain (Figs. 9, 10a)."""
ALPHA_HUGE = 200.0
"""CM01's huge gain (Figs. 9, 10b)."""

IMPERFECT_TAU = 0.1
"""Time constant (s) of the imperfect robot's first-order velocity lag (CM01 Fig. 13: the
command's jumps are 'smoothed by the dynamics of the robot' over about one period)."""
IMPERFECT_DELAY = 1
"""Transport delay of the imperfect robot, in control periods."""
IMPERFECT_QDOT_MAX = 0.05
"""The imperfect robot's controller scales the whole command so that no joint exceeds this
speed (m/s or rad/s; docs/formulas.md §12.3): above the ~0.05 peak of iterative-smooth,
below the ~0.2 peaks of iterative's velocity jumps. The saturation sweep figure shows the
whole range."""

GPM = {a: f"gpm alpha={a:g}" for a in (ALPHA_SMALL, ALPHA_ENOUGH, ALPHA_MODERATE, ALPHA_HUGE)}
"""Labels of the gpm runs by α."""
AUTO = "gpm-auto"
"""gpm-auto with our critical-axis rule (candidates from the prediction q̂)."""
AUTO_CURRENT = "gpm-auto current"
"""gpm-auto with CM01 §II-C's rule as printed (candidates from the current q)."""
ITERATIVE = ("iterative-basic", "iterative", "iterative-smooth", "iterative-smooth-e2")
"""The four variants of the iterative scheme (Figs. 11-12)."""


def imperfect(label: str) -> str:
    """Label of a run of ``label``'s law on the imperfect robot."""
    return f"{label} (imperfect robot)"


def imperfect_robot(exp: Experiment) -> None:
    """Put the imperfect robot's drives (lag ``IMPERFECT_TAU``, one period of delay) on ``exp``.

    The controller's velocity saturation (``IMPERFECT_QDOT_MAX``) is a simulation option
    of the run (``RunSpec.options``), applied to the command before it is sent.
    """
    from redservo.hardware.actuators import ActuatorModel

    exp.actuator = ActuatorModel(tau=IMPERFECT_TAU, delay_steps=IMPERFECT_DELAY)


def _law_options(label: str) -> dict[str, float]:
    return {"alpha": ALPHA_MODERATE} if label == "iterative-smooth-e2" else {}


RUNS: tuple[RunSpec, ...] = (
    RunSpec("classical", "classical"),
    *(RunSpec(label, "gpm", {"alpha": a}) for a, label in GPM.items()),
    RunSpec(AUTO, "gpm-auto"),
    RunSpec(AUTO_CURRENT, "gpm-auto", {"critical_rule": "current"}),
    *(RunSpec(label, label, _law_options(label)) for label in ITERATIVE),
    *(
        RunSpec(
            imperfect(label),
            label,
            _law_options(label),
            setup=imperfect_robot,
            options={"qdot_max": IMPERFECT_QDOT_MAX},
        )
        for label in ITERATIVE
    ),
)
"""The runs of Figs. 9–13: the laws on the ideal robot, gpm-auto with both critical-axis
rules, and the four iterative variants on the imperfect robot."""
