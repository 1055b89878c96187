"""The claims of CM01 §V-A1–2 (no avoidance, gpm, gpm-auto) as named checks on the gaze logs.

The iterative scheme's (§V-A3) are in :mod:`~redservo.reproduction.cm01_gaze_iterative`.

Criteria (tolerances are also stated in each verdict's evidence):

* an axis *crosses* its threshold when its normalized band excess
  ``max(|q_norm| - (1 - 2ρ), 0)`` exceeds ``CROSS_TOL``;
* *oscillations on q1*: sign reversals of q̇1 counted over the steps where ``|q̇1|``
  exceeds 1 % of its maximum over the run;
* *exponential decay* of the image error: a least-squares line through ``log ‖e‖`` versus
  t has R² >= 0.99 and a rate within 15 % of the nominal ``-ln(1 - λ dt)/dt``;
* *large-gain transient of gpm-auto*: the peak α lies in the first quarter of the run and
  is at least 10 times the median α of the second half;
* *discontinuity*: the simulator's ``max ‖q̇_{k+1} - q̇_k‖``;
* *faster convergence*: fewer iterations to ``‖e1‖ < tolerance``.
"""

from __future__ import annotations

import numpy as np

from redservo.reproduction.base import Runs
from redservo.reproduction.checks import IMPL, PAPER, Check, Verdict, registrar
from redservo.reproduction.cm01_gaze_runs import (
    ALPHA_ENOUGH,
    ALPHA_HUGE,
    ALPHA_MODERATE,
    ALPHA_SMALL,
    AUTO,
    AUTO_CURRENT,
    GPM,
)
from redservo.reproduction.metrics import (
    as_int_list,
    first,
    hit,
    reversals,
    stopped_speed,
    succeeded,
    threshold,
    translation_speed,
)

__all__ = ["CHECKS", "CROSS_TOL", "STOP_TOL"]

CROSS_TOL = 1e-9
"""Normalized band excess above which an axis counts as having crossed its threshold."""
STOP_TOL = 1e-9
"""|q̇_k| (rad/s or m/s) below which a constrained axis counts as stopped."""

CHECKS: list[Check] = []
check = registrar(CHECKS)


def _thr(runs: Runs) -> float:
    return threshold(runs.base.limits.rho)


# -- classical and gpm ---------------------------------------------------------------------


@check(
    "classical-hits-axis-1",
    IMPL,
    "Set-up check: with no avoidance (classical) a joint limit is hit, axis 1 (CM01: at "
    "iteration 54), so there is something to avoid",
    "CM01 §V-A2, Fig. 9a",
)
def _classical(runs: Runs) -> Verdict:
    """CM01: "The robot encounters the limit of axis 1 at iteration 54 for α = 0 (i.e., no
    secondary task)". Our start was searched for this outcome: a set-up check."""
    cl = runs["classical"]
    axis, it = hit(cl)
    ok = cl.outcome == "joint_limit" and axis == 1
    return Verdict(ok, {"outcome": cl.outcome, "axis": axis, "iteration": it, "CM01": 54})


@check(
    "small-alpha-hits-a-limit",
    PAPER,
    f"gpm with too small an α (ours {ALPHA_SMALL:g}; CM01 1.5) hits a joint limit",
    "CM01 §V-A2, Fig. 9",
)
def _small_alpha(runs: Runs) -> Verdict:
    r = runs[GPM[ALPHA_SMALL]]
    axis, it = hit(r)
    ev = {"alpha": ALPHA_SMALL, "outcome": r.outcome, "axis": axis, "iteration": it}
    return Verdict(
        r.outcome == "joint_limit", ev, "CM01's α = 1.5 hits axis 5 after iteration 180."
    )


@check(
    "small-alpha-hits-axis-5",
    PAPER,
    "... and the limit it hits is that of axis 5 (CM01: α = 1.5 hits axis 5)",
    "CM01 §V-A2, Fig. 9b",
)
def _small_alpha_axis(runs: Runs) -> Verdict:
    axis, it = hit(runs[GPM[ALPHA_SMALL]])
    note = (
        "Here the too-small gain lets axis 1 reach its limit. In our search (about 10 000 "
        "draws) the few draws where a small α failed on axis 5, as in CM01, also had gpm-auto "
        "hitting a limit or iterative diverging, so none was kept."
    )
    return Verdict(axis == 5, {"axis": axis, "iteration": it}, "" if axis == 5 else note)


@check(
    "larger-alpha-succeeds",
    PAPER,
    f"The task is achieved with α ≥ 2: gpm with α = {ALPHA_MODERATE:g} (CM01's value) succeeds",
    "CM01 §V-A2",
)
def _larger_alpha(runs: Runs) -> Verdict:
    """CM01 §V-A2: "The task is achieved with α ≥ 2." Checked at α = 2, CM01's own value (our
    α = 0.5 also succeeds nominally; it is reported as evidence, not required)."""
    ok = {a: runs[GPM[a]] for a in (ALPHA_ENOUGH, ALPHA_MODERATE)}
    ev = {f"outcome α={a:g}": r.outcome for a, r in ok.items()}
    ev.update({f"iterations α={a:g}": r.summary["iterations"] for a, r in ok.items()})
    return Verdict(succeeded(ok[ALPHA_MODERATE]), ev)


@check(
    "huge-alpha-velocity-peaks",
    IMPL,
    f"A very large α ({ALPHA_HUGE:g}) gives large camera velocity peaks (CM01: translation "
    "velocities of nearly 1 m/s); an implementation check, not a reproduction: gpm's "
    "secondary velocity is proportional to α, so it follows from the law",
    "CM01 §V-A2, Fig. 10b",
)
def _huge_speed(runs: Runs) -> Verdict:
    v_h = translation_speed(runs[GPM[ALPHA_HUGE]])
    v_m = translation_speed(runs[GPM[ALPHA_MODERATE]])
    ev = {
        f"max translation speed α={ALPHA_HUGE:g} (m/s)": v_h,
        f"max translation speed α={ALPHA_MODERATE:g} (m/s)": v_m,
        "ratio": v_h / v_m if v_m > 0 else float("inf"),
        "criterion": ">= 0.5 m/s and >= 10x the moderate α",
    }
    return Verdict(v_h >= 0.5 and v_h >= 10.0 * v_m, ev)


@check(
    "huge-alpha-oscillates-q1",
    PAPER,
    f"... and oscillations on q1 (α = {ALPHA_HUGE:g})",
    "CM01 §V-A2, Fig. 9a",
)
def _huge_oscillation(runs: Runs) -> Verdict:
    huge, mod = runs[GPM[ALPHA_HUGE]], runs[GPM[ALPHA_MODERATE]]
    rev_h, rev_m = reversals(huge.log.qdot[:, 0]), reversals(mod.log.qdot[:, 0])
    ev = {
        f"q̇1 sign reversals α={ALPHA_HUGE:g}": rev_h,
        f"q̇1 sign reversals α={ALPHA_MODERATE:g}": rev_m,
        f"iterations α={ALPHA_HUGE:g}": huge.summary["iterations"],
        "dt (s)": runs.experiments[GPM[ALPHA_HUGE]].options.dt,
        "criterion": ">= 10 and >= 5x the moderate α (|q̇1| > 1 % of its max)",
    }
    return Verdict(rev_h >= 10 and rev_h >= 5 * max(rev_m, 1), ev)


# -- gpm-auto, both critical-axis rules ------------------------------------------------------


def _transient(runs: Runs, label: str) -> Verdict:
    auto = runs[label]
    a = auto.log.alpha
    n = a.size
    k_peak = int(np.nanargmax(a))
    a_late = float(np.nanmedian(a[n // 2 :]))
    first5 = first(auto.log.constrained[:, 4])
    ev = {
        "peak α": float(a[k_peak]),
        "at iteration": k_peak,
        "of iterations": n,
        "α at iteration 0": float(a[0]),
        "median α, second half": a_late,
        "max camera speed / classical's": translation_speed(auto)
        / translation_speed(runs["classical"]),
        "criterion": "peak in the first quarter and >= 10x the late median",
    }
    note = (
        "The peak comes when axis 5 takes over (its e2 is then still tiny), not at iteration 0."
        if k_peak == first5 and k_peak > 0
        else ""
    )
    return Verdict(k_peak <= n // 4 and float(a[k_peak]) >= 10.0 * a_late, ev, note)


def _order(runs: Runs, label: str) -> Verdict:
    auto = runs[label]
    c = auto.log.constrained
    f1, f5 = first(c[:, 0]), first(c[:, 4])
    ev = {
        "first iteration axis 1 stopped": f1,
        "first iteration axis 5 stopped": f5,
        "outcome": auto.outcome,
    }
    return Verdict(f1 is not None and f5 is not None and f1 < f5, ev)


_RULE_NOTE = {
    AUTO: "our rule: an axis is a candidate when its prediction q̂ is in the band",
    AUTO_CURRENT: "CM01 §II-C's rule as printed: when its current position q is in the band",
}


def _declare_auto(label: str, suffix: str) -> None:
    """The two gpm-auto checks for one critical-axis rule.

    The early transient is an implementation check: α of eq. 9 is proportional to ‖e1‖, which
    is largest at the start, so any run passes "peak in the first quarter, ≥ 10× the
    second-half median". The order of the stopped axes is a paper claim (CM01 §V-A2); the
    second rule's check restates the first's statement (counted once in the headline).
    """

    def transient(runs: Runs) -> Verdict:
        return _transient(runs, label)

    def order(runs: Runs) -> Verdict:
        return _order(runs, label)

    first_rule = suffix == ""
    check(
        f"gpm-auto-early-transient{suffix}",
        IMPL,
        "gpm-auto computes large α values early in the run, a large-gain transient (CM01 "
        "Fig. 10c); α ∝ ‖e1‖ (eq. 9) makes it so in any run — "
        f"{_RULE_NOTE[label]}",
        "CM01 §V-A2, Fig. 10c",
        statement="" if first_rule else "gpm-auto-early-transient",
    )(transient)
    check(
        f"gpm-auto-axis-1-then-5{suffix}",
        PAPER,
        "gpm-auto first stops axis 1, then axis 5 overtakes it as the most critical axis "
        f"(CM01: after iteration 80) — {_RULE_NOTE[label]}",
        "CM01 §V-A2",
        statement="" if first_rule else "gpm-auto-axis-1-then-5",
    )(order)


_declare_auto(AUTO, "")
_declare_auto(AUTO_CURRENT, "-current")


@check(
    "gpm-auto-one-axis-at-a-time",
    IMPL,
    "gpm-auto stops one axis at a time, to zero speed (eq. 9)",
    "CM01 §II-C",
)
def _one_axis(runs: Runs) -> Verdict:
    auto = runs[AUTO]
    c = auto.log.constrained
    speed = stopped_speed(auto.log)
    ev = {
        "max axes stopped at once": int(c.sum(axis=1).max()),
        "axes stopped": as_int_list(np.flatnonzero(c.any(axis=0))),
        "max |q̇_k| of the stopped axis": speed,
        "outcome": auto.outcome,
    }
    return Verdict(bool(c.any()) and int(c.sum(axis=1).max()) == 1 and speed <= STOP_TOL, ev)
