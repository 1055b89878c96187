"""CM01 §V-A1–3, Figs. 8–13: the Afma6 eye-in-hand camera gazes at a point (m = 2, n = 6, n_a = 4).

The scenario ``cm01-gaze`` starts near the limits of axes 1 and 3 (both in their bands)
with axis 5 just above its lower threshold; the task brings the point to the image centre.
The runs (:mod:`~redservo.reproduction.cm01_gaze_runs`) are those of CM01's Figs. 9–12:
no avoidance, the gradient projection method with several fixed gains α and with the
automatic gain of eq. 9 (with our critical-axis rule and with CM01 §II-C's rule as printed,
docs/formulas.md §6.2), and the four variants of the iterative scheme; then the four
iterative variants on an *imperfect robot* (lagging, delayed drives and a velocity
saturation), for CM01 Fig. 13 and for CM01's statement that the smoothed variant converges
faster on the real robot. The claims are named checks
(:mod:`~redservo.reproduction.cm01_gaze_checks` and
:mod:`~redservo.reproduction.cm01_gaze_iterative`, criteria there); the figures are in
:mod:`~redservo.reproduction.cm01_gaze_figures`.

Axes are numbered from 1 in claims and figures (axis 1 = ``q[0]``).

Decisions (also in docs/decisions.md, "Reproduction"):

* **Scenario.** CM01 gives neither the start nor the target; both come from a random
  search documented in the scenario file and in :data:`NOTES`. λ = 0.3 1/s, dt = 0.08 s
  (CM01's period).
* **α values.** Ours are 0.25 (fails), 0.5 (the smallest of our grid that succeeds),
  2 (CM01's moderate gain, Fig. 10a) and 200 (CM01's huge gain, Fig. 10b). CM01's
  threshold between failure and success is 1.5/2; ours is 0.25/0.5 because the gain of
  the gradient term depends on the scaling of e2 (``s_i/Δq_i``, eq. 6), on λ dt and on
  the geometry, none of which CM01 reports.
* **Thresholds.** ρ = 0.1 puts q̃ at ±0.8 in normalized coordinates (CM01 eq. 3,
  docs/formulas.md §5.1), not at the ±0.9 of CM01's text.
* **Imperfect robot.** Drives with a first-order velocity lag τ = 0.1 s and one period of
  transport delay (:class:`redservo.hardware.actuators.ActuatorModel`), and a controller
  that scales the whole command so that no joint exceeds 0.05 m/s or rad/s
  (docs/formulas.md §12.3). CM01 reports neither; the lag is of the order of the period,
  as CM01 Fig. 13 suggests, and the saturation lies between the peak speeds of
  iterative-smooth (~0.05) and of iterative's jumps (~0.2). The figure
  ``smooth_vs_saturation.png`` shows the iteration counts for every saturation level.
"""

from __future__ import annotations

from redservo.reproduction.base import ExperimentSpec
from redservo.reproduction.cm01_gaze_checks import CHECKS as GPM_CHECKS
from redservo.reproduction.cm01_gaze_figures import figures
from redservo.reproduction.cm01_gaze_iterative import CHECKS as ITERATIVE_CHECKS
from redservo.reproduction.cm01_gaze_runs import (
    ALPHA_ENOUGH,
    ALPHA_HUGE,
    ALPHA_MODERATE,
    ALPHA_SMALL,
    RUNS,
)
from redservo.reproduction.metrics import decay_fit, reversals

__all__ = [
    "ALPHA_ENOUGH",
    "ALPHA_HUGE",
    "ALPHA_MODERATE",
    "ALPHA_SMALL",
    "EXPERIMENTS",
    "NOTES",
    "SPEC",
    "decay_fit",
    "reversals",
]

NOTES = (
    "CM01 gives neither the start pose nor the target. The start (normalized q1 = -0.864 and "
    "q3 = +0.898, both in their bands; q5 = -0.770, 0.039 rad above its lower threshold; "
    "A = 1.405 rad) and the point (0.134, 0.279, 0.866) m in the start camera frame come from "
    "a throwaway random search of about 10 000 draws (q1, q3 in their bands, q5 just above its "
    "threshold, A anywhere, a point at 0.6-2.5 m anywhere in the image). We kept the draws "
    "where classical hits axis 1, iterative-basic lets q5 cross its threshold while iterative "
    "keeps it out, the other iterative variants converge, gpm fails with a small α and "
    "succeeds with a larger one, and gpm-auto stops axis 1 first and axis 5 later (searched "
    "at λ = 0.5 1/s, dt = 0.08 s). Re-run at λ = 0.3 1/s (dt = 0.08 s, CM01's period), only "
    "one of them also had gpm-auto converge with a large early α transient and α = 200 "
    "make q1 oscillate; it is this scenario, where classical hits axis 1 at iteration 55 "
    "(CM01: 54). The α values (0.25, 0.5, 2, 200) differ from CM01's (1.5 fails, ≥ 2 "
    "succeeds) because the gradient's gain depends on the scaling of e2, on λ dt and on the "
    "geometry. With ρ = 0.1 the thresholds are at ±0.8 in normalized coordinates (CM01 eq. 3), "
    "not at the ±0.9 of CM01's text. gpm-auto runs twice: with our critical-axis rule (an axis "
    "is a candidate once its prediction q̂ enters the band) and with CM01 §II-C's rule as "
    "printed (once its current position q does); on this start both stop the same axes at "
    "the same iterations. The imperfect robot (CM01 Fig. 13 and the 'faster convergence' "
    "of iterative-smooth, which CM01 measured on the real robot) has drives with a "
    "first-order lag τ = 0.1 s and one period of delay, and a controller that scales the "
    "whole command so that no joint exceeds 0.05 m/s or rad/s. The quick version (tests) "
    "doubles dt to 0.16 s."
)

FRAGILITY = (
    "Measured with `redservo reproduce --only cm01-gaze --robustness 20 --no-pixel-noise` "
    "(seed 0; the image factors were not swept in that run, for time). "
    "Every claim that is not robust has one dominant factor, with a sharp threshold. "
    "*gpm α = 2 succeeds* and *gpm-auto stops axis 1, then axis 5* (both "
    "critical-axis rules) are broken by the **depth error** alone (7/20 and 9/20 with it, 19 or 20 "
    "of 20 with any other single factor): α = 2 succeeds for every depth factor in ×0.93-×1.12 and "
    "for none outside ×0.90-×1.17; gpm-auto keeps its order in ×0.93-×1.19 only. A wrong "
    "depth rescales the task's motion J1⁺e1 towards the limits while the gradient term does "
    "not change, so the gain that balances them moves: this is the **method's** fragility, the "
    'one CM01 states itself ("tuning α is therefore performed based on trial and error. '
    "This solution is not acceptable.\"), and CM01's real set-up, with its own depth "
    "estimate, would shift the good α the same way. *α = 200 makes q1 oscillate* depends on "
    "the **period** alone: 13/13 set-ups at 80 ms, CM01's period (\"Each iteration is "
    "achieved in 80 ms\"), 0/7 at 40 ms, where the same α λ dt is half as large; CM01's "
    "own set-up keeps it, so the sweep's 40 ms draws, not the method or the paper, make it "
    "look fragile. *A too small α hits a limit* (13/20) fails with a depth factor above "
    "×1.08 (0/8 there; a larger assumed depth shrinks the task's motion, so α = 0.25 is "
    "enough), and with 6 of 20 start and 4 of 20 target shifts: our α = 0.25 sits close to "
    "the gain that succeeds on this start, as CM01's 1.5 against 2 does on its own. "
    "*iterative-smooth-e2 moves the axes away* (11/20) fails with the depth error alone, "
    "for factors outside ×0.88-×1.19: its e2 uses gpm's gradient with α = 2, so it "
    "plausibly shares that sensitivity (not separately tested)."
)

SPEC = ExperimentSpec(
    id="cm01-gaze",
    title="CM01 §V-A1–3: the Afma6 gazes at a point (m = 2, n = 6, n_a = 4)",
    paper="Chaumette & Marchand 2001, §V-A1–3, Figs. 8–13",
    scenario="cm01-gaze",
    runs=RUNS,
    figures=figures,
    checks=(*GPM_CHECKS, *ITERATIVE_CHECKS),
    fast=("control.dt=0.16",),
    notes=NOTES,
    fragility=FRAGILITY,
)
"""The experiment of CM01 §V-A1–3."""

EXPERIMENTS: tuple[ExperimentSpec, ...] = (SPEC,)
