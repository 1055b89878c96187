"""MC05 §V-B (Figs. 5-7): directional redundancy with a 4-DOF task and occlusion avoidance.

The task keeps only ``(xn, yn, an, α)`` (centering, zoom, rotation about the optical axis;
scenario option ``features[0].components = [0, 1, 2, 3]``), so two DOF are free. A sphere
crosses the line of sight. Runs: ``no avoidance`` (``classical`` with ``occlusion.avoid =
false``), ``classical projector`` (``classical``: the occlusion force of MC05 eq. 31 is the
``secondary`` command, projected with ``J1^⊥``) and ``directional`` (the same force through
MC05's operator, ``use_joint_limits = False`` so that only the occlusion force acts). The
runs do not stop at convergence (``stop_at_convergence = false``): the sphere must have gone
by, not just been outrun.

Check criteria (decisions; MC05 gives no numbers; shared ones in
:mod:`~redservo.reproduction.mc05`):

* *occluded*: the simulator's outcome ``occluded`` (a dot inside the sphere's image disc while
  the sphere is nearer; docs/formulas.md §9.4), or ``feature_lost`` when an image sensor
  measures the features (the sphere hides a dot from the detector first);
* *avoided*: ``directional`` ends ``converged`` after the whole run, and the smallest image
  clearance between the disc and the dots is reported;
* *motion along the optical axis* (Fig. 5): ``max_t |v_z|`` of the directional avoidance twist
  is at least ``VZ_MIN`` m/s and ``VZ_RATIO`` times the classical projector's;
* *by construction* (implementation checks): the classical projector's avoidance does not act
  on the task at all (``max ‖J1 q̇2‖ <= TASK_ZERO`` times the directional one's) and the directional one only ever
  decreases the error (``e1 · J1 q̇2 <= 0``, MC05 eq. 9); ``‖e1‖`` decreases at every step by
  at least ``(1 - λ dt)``;
* *Fig. 7, per feature*: during the avoidance (the iterations where ``‖J1 q̇2‖`` exceeds
  ``ACTIVE_FRACTION`` of its maximum, the directional avoidance acting on the task), each
  feature's error is compared with the classical exponential from its value when the
  avoidance starts, ``e_i(k0)(1 - λ dt)^(k - k0)``: the feature is *accelerated* when
  ``Σ|e_i| / Σ|e_i^ref|`` over that window is at most ``ACCELERATION_RATIO``, *pushed away*
  when ``|e_i|`` grows above ``PUSH_TOL`` times its value at ``k0`` or overshoots zero by more
  than ``PUSH_TOL - 1`` of it. MC05: "the decreasing speed of some visual features has been
  accelerated" — reproduced if some feature is accelerated and none is pushed away;
* *Fig. 7, after*: from the first iteration after which the avoidance motion ``‖q̇2‖`` stays
  below ``AFTER_FADE`` of its peak (the occluder has gone by), the command changes the task
  exactly as the main task asks: ``‖J1 q̇2‖ <= AFTER_TOL λ‖e1‖`` in the controller's model
  ("when the occlusion ends, the features decrease is no longer modified"). With the exact
  model this means every feature decreases by ``(1 - λ dt)`` per step again (reported too);
  with a depth error the decrease of the classical law itself is no longer exponential.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from redservo.reproduction import mc05_fragility
from redservo.reproduction.base import ExperimentSpec, Runs, RunSpec
from redservo.reproduction.checks import IMPL, PAPER, Check, Verdict, registrar
from redservo.reproduction.mc05 import (
    ACCELERATION_RATIO,
    DECAY_SLACK,
    FEATURES,
    avoidance_split,
    clearance,
    worst_step,
)
from redservo.reproduction.mc05_occlusion_figures import figures
from redservo.reproduction.metrics import succeeded

__all__ = ["CHECKS", "CLASSICAL", "DIRECTIONAL", "EXPERIMENTS", "NONE", "figure7_features"]

VZ_MIN = 0.005
"""Smallest peak optical-axis speed (m/s) of the directional avoidance called 'not null'."""
VZ_RATIO = 3.0
"""Directional / classical-projector ratio of the peak optical-axis avoidance speed."""
TASK_ZERO = 0.05
"""Largest ‖J1 q̇2‖ of an avoidance motion called 'invisible to the task', relative to the
directional avoidance's largest. The split is rebuilt from the logs: exact (1e-16) with the
ideal sensor, about 1 % off with an image sensor (the moments' interaction matrix depends on
every detected dot, which the log does not keep)."""
ACTIVE_FRACTION = 0.01
"""The directional avoidance acts on the task while ‖J1 q̇2‖ exceeds this fraction of its max."""
PUSH_TOL = 1.05
"""A feature error growing above this factor of its value (or overshooting zero by more than
``PUSH_TOL - 1`` of it) when the avoidance starts is 'pushed away'."""
AFTER_TOL = 0.01
"""Relative tolerance on the per-step factor ``(1 - λ dt)`` after the avoidance."""
AFTER_FLOOR = 1e-5
"""Feature errors below this (normalized units) are left out of the per-step factor."""
AFTER_FADE = 1e-3
"""The avoidance motion has died out once ``‖q̇2‖`` stays below this fraction of its peak."""
NONE = "no avoidance"
CLASSICAL = "classical projector"
DIRECTIONAL = "directional"
OCCLUDED = ("occluded", "feature_lost")
"""Outcomes that mean the target was hidden (feature_lost: an image sensor lost a dot)."""

RUNS = (
    RunSpec(NONE, "classical", overrides=("occlusion.avoid=false",)),
    RunSpec(CLASSICAL, "classical"),
    RunSpec(DIRECTIONAL, "directional", {"use_joint_limits": False}),
)


# --------------------------------------------------------------------------- Fig. 7 per feature


def _active(runs: Runs) -> tuple[np.ndarray, Any]:
    """(N,) iterations where the directional avoidance acts on the task, and the split."""
    split = avoidance_split(runs[DIRECTIONAL], runs.experiments[DIRECTIONAL])
    effect = np.linalg.norm(split.task2, axis=1)
    peak = float(effect.max()) if effect.size else 0.0
    return effect > ACTIVE_FRACTION * peak if peak > 0 else np.zeros(effect.size, bool), split


def figure7_features(runs: Runs) -> dict[str, Any]:
    """Per task feature, how the directional avoidance changed its error (module docstring).

    Returns:
        ``{"window": [k0, k1], "ratio": {...}, "growth": {...}, "overshoot": {...},
        "accelerated": [...], "pushed away": [...]}``: the ratio ``Σ|e_i| / Σ|e_i^ref|`` over
        the window, the largest ``|e_i| / |e_i(k0)|``, the largest overshoot past zero as a
        fraction of ``|e_i(k0)|``.
    """
    d = runs[DIRECTIONAL]
    exp = runs.experiments[DIRECTIONAL]
    active, _ = _active(runs)
    idx = np.flatnonzero(active)
    if idx.size == 0:
        raise ValueError("the directional avoidance never acts on the task")
    k0, k1 = int(idx[0]), int(idx[-1])
    e = d.log.e1[k0 : k1 + 1]
    steps = np.arange(e.shape[0])
    ref = e[0] * (1.0 - exp.options.constant_lam * exp.options.dt) ** steps[:, None]
    names = FEATURES[: e.shape[1]]
    out: dict[str, Any] = {"window": [k0, k1], "ratio": {}, "growth": {}, "overshoot": {}}
    for i, name in enumerate(names):
        e0 = abs(float(e[0, i]))
        den = float(np.sum(np.abs(ref[:, i])))
        out["ratio"][name] = float(np.sum(np.abs(e[:, i]))) / den if den > 0 else float("nan")
        out["growth"][name] = float(np.max(np.abs(e[:, i]))) / e0 if e0 > 0 else float("inf")
        past = -np.sign(e[0, i]) * e[:, i]  # > 0 once the error has crossed zero
        out["overshoot"][name] = float(max(past.max(), 0.0)) / e0 if e0 > 0 else 0.0
    out["accelerated"] = [n for n in names if out["ratio"][n] <= ACCELERATION_RATIO]
    out["pushed away"] = [
        n for n in names if out["growth"][n] > PUSH_TOL or out["overshoot"][n] > PUSH_TOL - 1.0
    ]
    return out


def _rounded(d: dict[str, float]) -> dict[str, float]:
    return {k: round(v, 3) for k, v in d.items()}


# --------------------------------------------------------------------------- checks

CHECKS: list[Check] = []
check = registrar(CHECKS)


@check(
    "no-avoidance-occluded",
    IMPL,
    "Set-up check: without any avoidance the target is quickly occluded, so there is "
    "something to avoid",
    "MC05 §V-B",
)
def _none(runs: Runs) -> Verdict:
    """MC05 §V-B: "Without any avoidance law, the visual target is quickly occluded, which
    makes the servo fail." The occluder's path was chosen for it: a set-up check."""
    none = runs[NONE]
    dt = runs.experiments[NONE].options.dt
    return Verdict(
        none.outcome in OCCLUDED, {"outcome": none.outcome, "time (s)": (len(none.log) - 1) * dt}
    )


@check(
    "classical-projector-occluded",
    IMPL,
    "Set-up check: with the classical projector (2 free DOF) the avoidance is too slow: "
    "occluded, so the directional projector has something to improve on",
    "MC05 §V-B, Fig. 6a",
)
def _classical(runs: Runs) -> Verdict:
    """MC05 §V-B: "the secondary control law is not fast enough to avoid the occlusion (Fig.
    6a)". Whether it is fast enough depends on the occluder's speed, which we chose: a set-up
    check."""
    cl, none = runs[CLASSICAL], runs[NONE]
    dt = runs.experiments[CLASSICAL].options.dt
    ev = {
        "outcome": cl.outcome,
        "time (s)": (len(cl.log) - 1) * dt,
        "delay wrt no avoidance (s)": (len(cl.log) - len(none.log)) * dt,
    }
    return Verdict(cl.outcome in OCCLUDED, ev)


@check(
    "directional-avoids",
    PAPER,
    "With the directional projector the occlusion is avoided and the task completes",
    "MC05 §V-B, Fig. 6b",
)
def _directional(runs: Runs) -> Verdict:
    """MC05 §V-B: "This motion is available using our approach (Fig. 5). The robot velocity
    is fast enough to avoid the occlusion (Fig. 6-b)." (the task completes: checked too)"""
    d = runs[DIRECTIONAL]
    exp = runs.experiments[DIRECTIONAL]
    clear = clearance(exp, d) * exp.camera.px
    ev = {
        "outcome": d.outcome,
        "duration (s)": len(d.log) * exp.options.dt,
        "final ‖e1‖": float(d.log.error_norm[-1]),
        "min clearance dot-disc (px)": float(np.min(clear)),
        "final clearance (px)": float(clear[-1]),
    }
    ev["min margin (fraction of range)"] = d.summary["min_margin"]
    return Verdict(succeeded(d) and len(d.log) == exp.options.max_iterations, ev)


@check(
    "directional-moves-along-optical-axis",
    PAPER,
    "The directional avoidance moves the camera along its optical axis (non-null v_z), which "
    "the classical projector forbids (Fig. 5)",
    "MC05 §V-B, Fig. 5",
)
def _vz(runs: Runs) -> Verdict:
    s_cl = avoidance_split(runs[CLASSICAL], runs.experiments[CLASSICAL])
    s_d = avoidance_split(runs[DIRECTIONAL], runs.experiments[DIRECTIONAL])
    vz_cl = float(np.max(np.abs(s_cl.twist2[:, 2])))
    vz_d = float(np.max(np.abs(s_d.twist2[:, 2])))
    ev = {
        "max |v_z| avoidance, directional (m/s)": vz_d,
        "max |v_z| avoidance, classical projector (m/s)": vz_cl,
        "criterion": f">= {VZ_MIN} m/s and >= {VZ_RATIO:g}x the classical projector's",
    }
    return Verdict(vz_d >= VZ_MIN and vz_d >= VZ_RATIO * vz_cl, ev)


@check(
    "avoidance-acts-on-task-only-to-help",
    IMPL,
    "The classical projector's avoidance is invisible to the task (J1 q̇2 = 0); the "
    "directional one acts on it only to decrease the error (e1 · J1 q̇2 ≤ 0)",
    "docs/formulas.md §8.2",
)
def _task_effect(runs: Runs) -> Verdict:
    s_cl = avoidance_split(runs[CLASSICAL], runs.experiments[CLASSICAL])
    s_d = avoidance_split(runs[DIRECTIONAL], runs.experiments[DIRECTIONAL])
    task_cl = float(np.max(np.linalg.norm(s_cl.task2, axis=1)))
    task_d = float(np.max(np.linalg.norm(s_d.task2, axis=1)))
    e1 = runs[DIRECTIONAL].log.e1
    helps = float(np.einsum("ij,ij->i", e1, s_d.task2).max())
    scale = task_d * float(np.max(np.linalg.norm(e1, axis=1)))
    ev = {
        "max ‖J1 q̇2‖ classical projector": task_cl,
        "max ‖J1 q̇2‖ directional": task_d,
        "max e1·J1 q̇2 directional": helps,
        "criterion": f"classical ≤ {TASK_ZERO:g} × directional's; e1·J1 q̇2 ≤ {TASK_ZERO:g} × "
        "max‖e1‖ max‖J1 q̇2‖",
    }
    note = (
        "The split is rebuilt from the logged features; with an image sensor the moments' "
        "interaction matrix depends on every detected dot, not only on the logged features, "
        "hence the relative tolerance."
    )
    return Verdict(task_cl <= TASK_ZERO * task_d and helps <= TASK_ZERO * scale, ev, note)


@check(
    "error-norm-never-slowed",
    IMPL,
    "The avoidance never slows the main task: ‖e1‖ decreases at every step at least as fast "
    "as the classical exponential, (1 − λ dt) per step (MC05 eq. 9)",
    "docs/formulas.md §8.2",
)
def _never_slowed(runs: Runs) -> Verdict:
    d = runs[DIRECTIONAL]
    exp = runs.experiments[DIRECTIONAL]
    lam_dt = exp.options.constant_lam * exp.options.dt
    worst = worst_step(d, exp)
    ev = {"max ‖e1(k+1)‖/‖e1(k)‖ (while ‖e1‖ > 10 tol)": worst, "1 − λ dt": 1 - lam_dt}
    note = "Eq. 9 bounds the norm, in the SVD basis of J1; single features may grow (Fig. 7)."
    return Verdict(worst <= (1 - lam_dt) * (1 + DECAY_SLACK), ev, note)


@check(
    "features-accelerated",
    IMPL,
    "The decreasing speed of some visual features has been accelerated to enlarge the free "
    "space of the first task (Fig. 7, per feature); an implementation check, not a "
    "reproduction: eq. 9 lets the avoidance act on the task only to decrease its error",
    "MC05 §V-B, Fig. 7",
)
def _fig7_per_feature(runs: Runs) -> Verdict:
    """MC05 §V-B: "The decreasing speed of some visual features has been accelerated to
    enlarge the free space of the first task (Fig 7)." MC05 does not say that no feature is
    pushed away; those pushed are reported as evidence, not required."""
    f7 = figure7_features(runs)
    ok = bool(f7["accelerated"])
    ev = {
        "avoidance window (iterations)": f7["window"],
        "∫|e| / ∫|e ref| per feature": _rounded(f7["ratio"]),
        "max |e| / |e(k0)| per feature": _rounded(f7["growth"]),
        "overshoot past 0 / |e(k0)| per feature": _rounded(f7["overshoot"]),
        "accelerated": f7["accelerated"],
        "pushed away": f7["pushed away"],
    }
    note = (
        "MC05 eq. 9 only bounds the error norm (in the SVD basis of J1): the directional "
        "operator lets the avoidance move any combination of features that does not increase "
        "the norm, so single features can be pushed away while others are accelerated."
        if f7["pushed away"]
        else ""
    )
    return Verdict(ok, ev, note)


@check(
    "features-unmodified-after",
    IMPL,
    "When the occlusion ends, the features' decrease is no longer modified: from the time the "
    "avoidance motion has died out, the command changes the features exactly as the main task "
    f"asks, J1 q̇ = −λ e1 (within {AFTER_TOL:.0%} of λ‖e1‖)",
    "MC05 §V-B, Fig. 7",
)
def _after(runs: Runs) -> Verdict:
    """MC05 §V-B: "When the occlusion ends, the features decrease is no longer modified."
    Once the avoidance speed is small, J1 q̇ = −λ e1 follows nearly automatically: an
    implementation check."""
    d = runs[DIRECTIONAL]
    exp = runs.experiments[DIRECTIONAL]
    lam, dt = exp.options.constant_lam, exp.options.dt
    split = avoidance_split(d, exp)
    size = np.linalg.norm(split.qdot2, axis=1)
    alive = np.flatnonzero(size > AFTER_FADE * float(size.max()))
    if alive.size == 0 or alive[-1] + 1 >= len(d.log):
        raise ValueError("the avoidance motion never dies out")
    k1 = int(alive[-1]) + 1
    rel = np.linalg.norm(split.task2[k1:], axis=1) / np.maximum(
        lam * np.linalg.norm(d.log.e1[k1:], axis=1), 1e-300
    )
    e = d.log.e1[k1:]
    big = np.abs(e[:-1]) > AFTER_FLOOR
    step = np.divide(e[1:], e[:-1], out=np.ones_like(e[1:]), where=big)
    dev = np.abs(step[big] / (1.0 - lam * dt) - 1.0)
    ev = {
        "avoidance motion dies out at iteration": k1,
        "max ‖J1 q̇2‖ / (λ‖e1‖) after": float(rel.max()),
        "max |e_i(k+1)/e_i(k) / (1 − λ dt) − 1| after (exact model only)": float(dev.max())
        if dev.size
        else 0.0,
    }
    return Verdict(float(rel.max()) <= AFTER_TOL, ev)


EXPERIMENTS: tuple[ExperimentSpec, ...] = (
    ExperimentSpec(
        id="mc05-occlusion",
        title="MC05 §V-B — 4-DOF task and occlusion avoidance (Figs. 5-7)",
        paper="Mansard & Chaumette 2005, §V-B, Figs. 5-7",
        scenario="mc05-occlusion",
        runs=RUNS,
        figures=figures,
        checks=tuple(CHECKS),
        fast=("simulation.max_iterations=200", "simulation.tolerance=0.02"),
        fragility=mc05_fragility.OCCLUSION,
        notes=(
            "Scenario choice (a random search over target poses, sphere start, size and speed, "
            "beta and gain; details in the scenario file): the sphere hides the dots after "
            "about 1 s without avoidance. With the classical projector the sphere is occluding "
            "for every gain up to 2x the chosen one (the search's check), with the directional "
            "projector it is avoided for start speeds 0.8x-1.25x. use_joint_limits = False in "
            "the directional run, so that only the occlusion force acts (no axis reaches its "
            "band in this run anyway). The runs do not stop at convergence: the sphere has gone "
            "by when the 16 s end. The avoidance velocities of Fig. 5 are recomputed from the "
            "logs (q̇ − (−λ J1⁺ e1), mapped to the camera frame). The fast version runs 8 s "
            "with tolerance 0.02."
        ),
    ),
)
