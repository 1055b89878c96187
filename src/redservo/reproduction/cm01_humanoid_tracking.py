"""CM01 §V-B2 (Fig. 18): the humanoid torso tracks a point moving around it.

**Point tracking** (``cm01-humanoid-tracking``). A point at eye height moves on a
circle around the torso (130° to the right); the task keeps it at the image centre with
feed-forward of its known motion. Runs: ``classical``, ``iterative``, ``iterative-smooth``.
Definitions (decisions; CM01 only says "mainly the eyes are moving; when they move near their
joint limits the motion is automatically transferred to the neck, then to the pelvis"):

* *activation* of a group: the first iteration at which its largest normalized displacement
  from the start, ``max_{j in group} |q̃_j(k) - q̃_j(0)|`` with ``q̃ = 2(q - mid)/range``,
  reaches ``ACTIVATION = 0.25`` (an eighth of the range) (:func:`~redservo.reproduction.cm01_humanoid.group_activation`). CM01's
  order is eyes, neck, pelvis (the spine is not mentioned; it is reported).
* *transfer*: with ``k_eyes`` and ``k_neck`` the first iterations at which the law constrains a
  joint of the eyes and of the neck, and ``k_end`` the last iteration at which the target moves,
  the mean normalized speed of each group (``max_{j in group} 2|q̇_j|/range_j``) is largest for
  the eyes on ``[0, k_eyes)`` and for the neck on ``[k_eyes, k_neck)``, and the pelvis moves
  faster than the neck on ``[k_neck, k_end)`` (:func:`~redservo.reproduction.cm01_humanoid.group_speed_shares`). The eyes are not
  compared in the last phase: the eye tilt (range 30°) keeps correcting small vertical
  deviations while the trunk turns, which is large in normalized units.
* *small tracking error*: from the first iteration at which ``‖e1‖ <= MAX_TRACKING_ERROR``
  (normalized units; × 600 px) on, it stays there (the nominal start is centred; a perturbed
  one needs a few iterations to acquire the point).

Why it works: the minimum-norm solution spreads the gaze rotation over every rotational joint
in radians, so in normalized coordinates the eyes (30° of range) move 4-5 times faster than
the neck (120°) and the pelvis (140°) and reach their band first; the iterative scheme then
stops them and the same task motion is carried by the remaining joints.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from redservo.records.summary import SUCCESS_MARGIN
from redservo.reproduction.base import ExperimentSpec, Runs, RunSpec
from redservo.reproduction.checks import IMPL, PAPER, Check, Verdict, registrar
from redservo.reproduction.cm01_humanoid import (
    ACTIVATION,
    GROUP_ORDER,
    group_activation,
    group_panel,
    group_speed_shares,
    groups,
)
from redservo.reproduction.metrics import clear_of_limits, first, hit, succeeded
from redservo.robots.humanoid import JOINT_GROUPS

__all__ = ["CHECKS", "EXPERIMENTS", "MAX_TRACKING_ERROR"]

MAX_TRACKING_ERROR = 0.01
"""Largest ‖e1‖ (normalized image units, 6 px at 600 px) still called a small tracking error."""
LAWS = ("iterative-smooth", "iterative")
"""The runs the claims are checked on."""
TO_THE_END = ("converged", "max_iterations")
"""Outcomes of a tracking run that lasted the whole motion (no limit, target in view)."""


def _first_constrained(constrained: Any, idx: Any) -> int | None:
    return first(np.asarray(constrained)[:, list(idx)].max(axis=1))


def _motion_end(runs: Runs, label: str) -> int:
    """Last iteration at which the tracked object still moves (the log's end if it never stops)."""
    exp = runs.experiments[label]
    log = runs[label].log
    name = exp.task.terms[0].target
    p = np.array([exp.scene.wMo(name, float(t))[:3, 3] for t in log.t])
    moving = np.flatnonzero(np.linalg.norm(np.diff(p, axis=0), axis=1) > 1e-9)
    return int(moving[-1]) + 1 if moving.size else len(log)


def _transfer(runs: Runs, label: str) -> dict[str, Any]:
    """Activation, constraint events and per-phase group speeds of one tracking run."""
    exp, log = runs.experiments[label], runs[label].log
    grp = groups()
    act = group_activation(log.q_normalized, grp)
    k_eyes = _first_constrained(log.constrained, JOINT_GROUPS["eyes"])
    k_neck = _first_constrained(log.constrained, JOINT_GROUPS["neck"])
    k_pelvis = _first_constrained(log.constrained, JOINT_GROUPS["pelvis"])
    k_end = _motion_end(runs, label)
    rng = exp.limits.range
    p1 = group_speed_shares(log.qdot, rng, grp, 0, k_eyes if k_eyes is not None else len(log))
    p2 = (
        group_speed_shares(log.qdot, rng, grp, k_eyes, k_neck if k_neck is not None else k_end)
        if k_eyes is not None
        else {}
    )
    p3 = group_speed_shares(log.qdot, rng, grp, k_neck, k_end) if k_neck is not None else {}
    order_ok = all(act[g] is not None for g in ("eyes", "neck", "pelvis")) and (
        act["eyes"] < act["neck"] < act["pelvis"]  # type: ignore[operator]
    )
    transfer_ok = (
        bool(p1)
        and max(p1, key=p1.__getitem__) == "eyes"
        and bool(p2)
        and max(p2, key=p2.__getitem__) == "neck"
        and bool(p3)
        and p3["pelvis"] > p3["neck"]
    )
    return {
        "activation": act,
        "order_ok": order_ok,
        "constrained": {"eyes": k_eyes, "neck": k_neck, "pelvis": k_pelvis, "motion end": k_end},
        "phases": {"p1": p1, "p2": p2, "p3": p3},
        "transfer_ok": bool(transfer_ok),
    }


def _round(d: Mapping[str, float]) -> dict[str, float]:
    return {k: round(float(v), 4) for k, v in d.items()}


# --------------------------------------------------------------------------- checks

CHECKS: list[Check] = []
check = registrar(CHECKS)


@check(
    "order-eyes-neck-pelvis",
    PAPER,
    "At the beginning mainly the eyes move, then the neck, then the pelvis: the groups "
    f"activate in the order eyes → neck → pelvis (activation: normalized displacement from "
    f"the start ≥ {ACTIVATION})",
    "CM01 §V-B2, Fig. 18",
)
def _order(runs: Runs) -> Verdict:
    info = {label: _transfer(runs, label) for label in LAWS}
    ev = {f"{label} activation": info[label]["activation"] for label in LAWS}
    return Verdict(all(info[label]["order_ok"] for label in LAWS), ev)


@check(
    "motion-transferred",
    PAPER,
    "When the eyes near their limits the motion is transferred to the neck, then to the "
    "pelvis: the eyes move fastest until they are constrained, then the neck until it is "
    "constrained, after which the pelvis moves faster than the neck",
    "CM01 §V-B2, Fig. 18",
)
def _transferred(runs: Runs) -> Verdict:
    info = {label: _transfer(runs, label) for label in LAWS}
    ev: dict[str, Any] = {
        f"{label} first constrained": info[label]["constrained"] for label in LAWS
    }
    for label in LAWS:
        for p in ("p1", "p2", "p3"):
            ev[f"{label} {p} mean normalized speed"] = _round(info[label]["phases"][p])
    note = (
        "Phases: p1 = until an eye joint is constrained, p2 = until a neck joint is, p3 = "
        "until the target stops (module docstring)."
    )
    return Verdict(all(info[label]["transfer_ok"] for label in LAWS), ev, note)


@check(
    "small-tracking-error",
    IMPL,
    f"Once the point is acquired, the tracking error stays small (‖e1‖ ≤ {MAX_TRACKING_ERROR}, "
    "i.e. 6 px at 600 px); CM01 states no tracking error, so this checks our set-up",
    "docs/formulas.md §1.4",
)
def _error(runs: Runs) -> Verdict:
    """Not a CM01 statement (§V-B2 reports which joints move, not the error), and the nominal
    run starts centred: an implementation check of the tracking feed-forward."""
    px = float(runs.experiments["classical"].camera.px)
    ev: dict[str, Any] = {}
    ok = True
    for label in LAWS:
        err = runs[label].log.error_norm
        k = first(err <= MAX_TRACKING_ERROR)
        after = float(np.max(err[k:])) if k is not None else float("inf")
        ok = ok and after <= MAX_TRACKING_ERROR
        ev[f"{label} start error (px)"] = float(err[0]) * px
        ev[f"{label} acquired at iteration"] = k
        ev[f"{label} max error after (px)"] = after * px
        ev[f"{label} final error (px)"] = float(err[-1]) * px
    return Verdict(ok, ev)


@check(
    "tracks-to-the-end",
    PAPER,
    "The iterative method tracks the point to the end with no joint limit reached "
    "(iterative-smooth and iterative)",
    "CM01 §V-B2",
)
def _to_the_end(runs: Runs) -> Verdict:
    ev: dict[str, Any] = {f"{label} outcome": runs[label].outcome for label in LAWS}
    ev.update({f"{label} min margin": runs[label].summary["min_margin"] for label in LAWS})
    note = "The run lasts the whole motion; max_iterations means the final error is above the "
    note += "tolerance (see the tracking-error claim), not that tracking stopped."
    ev["required margin"] = SUCCESS_MARGIN
    ok = all(runs[label].outcome in TO_THE_END and clear_of_limits(runs[label]) for label in LAWS)
    return Verdict(ok, ev, "" if all(succeeded(runs[label]) for label in LAWS) else note)


@check(
    "classical-eyes-hit-limits",
    IMPL,
    "Set-up check: classical (no avoidance) runs the eyes into their limits, so the avoidance "
    "is needed (our trajectory was chosen for it)",
)
def _classical(runs: Runs) -> Verdict:
    cl = runs["classical"]
    exp = runs.experiments["classical"]
    axis, it = hit(cl)
    ev = {
        "outcome": cl.outcome,
        "joint": None if axis is None else exp.robot.joint_names[axis - 1],
        "iteration": it,
        "time (s)": None if it is None else it * exp.options.dt,
    }
    return Verdict(axis is not None and axis - 1 in JOINT_GROUPS["eyes"], ev)


# --------------------------------------------------------------------------- figures


def _plt() -> Any:
    from redservo.plots.style import _plt as plt

    return plt()


def _group_legend(ax: Any, joints: int) -> None:
    """The legend of a Fig. 18 row, right of the axes, 8 pt: the group's joints, then what
    the dotted and dash-dotted lines mean (in both columns)."""
    from matplotlib.lines import Line2D

    handles = [
        *ax.get_lines()[:joints],
        Line2D([], [], ls=":", color="0.3", lw=1.0, label="classical, until its limit hit"),
        Line2D([], [], ls="-.", color="tab:green", lw=0.9, label="activation"),
        Line2D([], [], ls="-.", color="tab:red", lw=0.9, label="first constrained"),
    ]
    ax.legend(
        handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0
    )


def figures(runs: Runs, out: Path) -> list[Path]:
    """Draw CM01 Fig. 18 and the tracking error into ``out``."""
    from redservo.plots.style import save

    plt = _plt()
    laws = ("iterative", "iterative-smooth")
    names = runs.experiments["classical"].robot.joint_names
    fig, axs = plt.subplots(len(GROUP_ORDER), 2, figsize=(12, 9), sharex=True)
    for col, label in enumerate(laws):
        log = runs[label].log
        info = _transfer(runs, label)
        cl = runs["classical"].log
        for row, group in enumerate(GROUP_ORDER):
            ax = axs[row, col]
            group_panel(ax, log.t, log.q_normalized, group, names, legend=False)
            for j in JOINT_GROUPS[group]:
                ax.plot(cl.t, cl.q_normalized[:, j], ":", color="0.3", lw=1.0)
            k = info["activation"].get(group)
            if k is not None:
                ax.axvline(log.t[k], color="tab:green", lw=0.9, ls="-.")
            kc = info["constrained"].get(group)
            if kc is not None:
                ax.axvline(log.t[kc], color="tab:red", lw=0.9, ls="-.")
            if col == len(laws) - 1:  # one legend per group, right of the figure, off the data
                _group_legend(ax, len(JOINT_GROUPS[group]))
        axs[0, col].set_title(label, fontsize=10)
        axs[-1, col].set_xlabel("time (s)")
    fig.suptitle(
        "CM01 Fig. 18 — humanoid tracking a point: normalized joint positions per group "
        "(dashed: thresholds at ±0.8)",
        fontsize=10,
    )
    paths = [save(fig, out / "fig18_humanoid_tracking.png")]

    fig, ax = plt.subplots(figsize=(7, 3))
    px = float(runs.experiments["classical"].camera.px)
    for label, res in runs.results.items():
        ax.plot(res.log.t, res.log.error_norm * px, lw=1.2, label=label)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("‖e1‖ (px)")
    ax.set_title("tracking error (feed-forward of the known target motion)", fontsize=9)
    ax.legend(fontsize=7)
    paths.append(save(fig, out / "humanoid_tracking_error.png"))
    return paths


# --------------------------------------------------------------------------- specs

RUNS = (
    RunSpec("classical", "classical"),
    RunSpec("iterative", "iterative"),
    RunSpec("iterative-smooth", "iterative-smooth"),
)

EXPERIMENTS: tuple[ExperimentSpec, ...] = (
    ExperimentSpec(
        id="cm01-humanoid-tracking",
        title="CM01 §V-B2 — humanoid torso tracking a point (Fig. 18)",
        paper="Chaumette & Marchand 2001, §V-B2, Fig. 18",
        scenario="cm01-humanoid-tracking",
        runs=RUNS,
        figures=figures,
        checks=tuple(CHECKS),
        notes=(
            "CM01 gives no trajectory: the point moves on a horizontal circle around the torso, "
            "130° to the right at 10°/s, more than eyes (±15°) and neck (±60°) can follow "
            "together, then stops for 2 s; the torso starts at rest. Feed-forward of the known "
            "target motion, λ = 1 1/s, dt = 40 ms. Activation and transfer are defined in the "
            "module docstring (activation: normalized displacement ≥ "
            f"{ACTIVATION}; transfer: the fastest group, in normalized units, between the "
            "constraint events). The neck (120° of range) and the pelvis yaw (140°) get nearly "
            "the same motion in radians from the minimum-norm solution, so their activations "
            "are close; the pelvis only dominates once the neck is stopped."
        ),
    ),
)
