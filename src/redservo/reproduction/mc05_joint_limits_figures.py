"""The figures of the MC05 joint-limit experiments (Figs. 2-4); the experiments are
:mod:`~redservo.reproduction.mc05_joint_limits` and :mod:`~redservo.reproduction.mc05_optical_axis`.

* ``fig2_joint_trajectories.png``: the joint plane of two axes with the limits and thresholds,
  and the limited axis against time (normalized with the real limits, also for the run
  without limits);
* ``fig3_projector_rank.png``: the rank of the directional projector, and when some axis is
  in its band;
* ``fig4_features.png``: the six feature errors of the three runs.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from redservo.reproduction.base import Runs
from redservo.reproduction.mc05 import FEATURES, in_band, pyplot

__all__ = ["figures_for"]

UNLIMITED = "classical-unlimited"


def _fig2(runs: Runs, out: Path, plane: tuple[int, int]) -> Path:
    from redservo.plots.style import save

    plt = pyplot()
    exp = runs.experiments["classical"]
    lim = exp.limits
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.6))
    lo, hi = lim.q_min, lim.q_max
    tlo, thi = lim.q_tilde_min, lim.q_tilde_max
    a, b = plane
    ax.add_patch(plt.Rectangle((lo[a], lo[b]), hi[a] - lo[a], hi[b] - lo[b], fill=False, color="k"))
    ax.add_patch(
        plt.Rectangle(
            (tlo[a], tlo[b]), thi[a] - tlo[a], thi[b] - tlo[b], fill=False, color="0.5", ls="--"
        )
    )
    styles = {
        "classical": ("tab:green", "-"),
        "directional": ("tab:blue", "-"),
        UNLIMITED: ("tab:green", ":"),
    }
    for label, (color, ls) in styles.items():
        q = runs[label].log.q
        ax.plot(q[:, a], q[:, b], color=color, ls=ls, lw=1.6, label=label)
        ax.plot(q[-1, a], q[-1, b], **_end_marker(runs, label, color))
    q0 = runs["classical"].log.q[0]
    ax.plot(q0[a], q0[b], "o", color="k", ms=5, label="start")
    ax.set_xlabel(_joint_label(exp.robot, a))
    ax.set_ylabel(_joint_label(exp.robot, b))
    ax.set_title(
        f"MC05 Fig. 2: joint plane (q{a + 1}, q{b + 1}); limits (black), thresholds (dashed)",
        fontsize=9,
    )
    _legend_outside(ax, below=True)
    allq = np.vstack([runs[label].log.q[:, [a, b]] for label in styles])
    span = np.ptp(allq, axis=0).max()
    c = 0.5 * (allq.min(axis=0) + allq.max(axis=0))
    half = 0.6 * span + 0.02
    ax.set_xlim(c[0] - half, c[0] + half)
    ax.set_ylim(c[1] - half, c[1] + half)
    ax.set_aspect("equal")
    j = _hit_axis(runs)
    for label, (color, ls) in styles.items():
        log = runs[label].log
        qn = lim.normalized(log.q)  # the real limits, also for the unlimited run
        bx.plot(log.t, qn[:, j], color=color, ls=ls, lw=1.4, label=label)
    for y in (1.0, -1.0):
        bx.axhline(y, color="k", lw=0.8)
    for y in (1 - 2 * lim.rho, -(1 - 2 * lim.rho)):
        bx.axhline(y, color="0.5", lw=0.8, ls="--")
    _mark_stop(bx, runs, lambda log: lim.normalized(log.q)[-1, j], "classical")
    bx.set_xlabel("t (s)")
    bx.set_ylabel(f"q{j + 1} (normalized: limits ±1, no unit)")
    bx.set_title(f"axis {j + 1} (the one classical hits) vs time", fontsize=9)
    _legend_outside(bx, below=True)
    return save(fig, out / "fig2_joint_trajectories.png")


def _joint_label(robot: Any, j: int) -> str:
    """``"q1 = x (m)"``: the joint's number, name and unit (m prismatic, rad revolute)."""
    unit = "m" if robot.joint_types[j] == "prismatic" else "rad"
    return f"q{j + 1} = {robot.joint_names[j]} ({unit})"


def _end_marker(runs: Runs, label: str, color: str) -> dict[str, Any]:
    """Keyword arguments of ``plot`` for the end of a run in the joint plane: ``×`` for a run
    stopped at a joint limit, a square for a run that ended otherwise; labelled for the legend."""
    hit = runs[label].summary["limit_hit"]
    if hit is not None:
        text = f"{label} stopped: q{int(hit['axis']) + 1} at its limit"
        return {"marker": "x", "ms": 9, "mew": 2, "color": color, "ls": "none", "label": text}
    return {"marker": "s", "ms": 6, "color": color, "ls": "none", "label": f"{label}: end"}


def _mark_stop(
    ax: Any, runs: Runs, value: Callable[[Any], float], label: str, *, text: bool = True
) -> None:
    """``×`` and "joint q_i at its limit, run stopped" where run ``label`` (drawn in the
    classical runs' colour) stopped at a limit (nothing when it did not); ``value(log)``: the
    y of its last point on this panel."""
    hit = runs[label].summary["limit_hit"]
    if hit is None:
        return
    log = runs[label].log
    t, y = float(log.t[-1]), float(value(log))
    color = "tab:green"  # the classical runs' colour
    ax.plot(t, y, "x", color=color, ms=8, mew=2, zorder=10)
    if not text:
        return
    ax.annotate(
        f"{label}: joint q{int(hit['axis']) + 1} at its limit, run stopped",
        (t, y),
        xytext=(10, 6),
        textcoords="offset points",
        fontsize=8,
        color=color,
        arrowprops={"arrowstyle": "-", "color": color, "lw": 0.6},
    )


def _last_error(log: Any, i: int) -> float:
    """The last value of feature error ``i`` of a run's log."""
    return float(log.e[-1, i])


def _legend_outside(ax: Any, *, below: bool = False) -> None:
    """The legend of ``ax`` outside its data region (below it, or to its right), 8 pt."""
    if below:
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=2)
    else:
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def _hit_axis(runs: Runs) -> int:
    hit = runs["classical"].summary["limit_hit"]
    return 0 if hit is None else int(hit["axis"])


def _fig3(runs: Runs, out: Path) -> Path:
    from redservo.plots.style import save

    plt = pyplot()
    d = runs["directional"]
    exp = runs.experiments["directional"]
    band = in_band(exp, d)
    fig, ax = plt.subplots(figsize=(7, 3))
    ax.step(d.log.t, d.log.projector_rank, where="post", color="tab:blue", label="rank of P_z")
    ax.fill_between(
        d.log.t,
        0,
        6.3,
        where=band,
        step="post",
        color="tab:orange",
        alpha=0.2,
        label="some axis in its band",
    )
    ax.set_ylim(-0.2, 6.3)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("DOF left for the avoidance")
    ax.set_title("MC05 Fig. 3: rank of the directional projector (directional run)", fontsize=9)
    ax.legend(fontsize=7)
    return save(fig, out / "fig3_projector_rank.png")


def _fig4(runs: Runs, out: Path) -> Path:
    from redservo.plots.style import save

    plt = pyplot()
    fig, axs = plt.subplots(2, 3, figsize=(11, 5.2), sharex=True)
    styles = {
        "directional": ("tab:blue", "-"),
        "classical": ("tab:green", "-"),
        UNLIMITED: ("tab:green", ":"),
    }
    for i, ax in enumerate(axs.flat):
        for label, (color, ls) in styles.items():
            log = runs[label].log
            ax.plot(log.t, log.e[:, i], color=color, ls=ls, lw=1.3, label=label)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_title(f"{FEATURES[i]} − {FEATURES[i]}*", fontsize=9)
        # the × on every panel, the text once
        _mark_stop(ax, runs, partial(_last_error, i=i), "classical", text=i == 0)
    _legend_outside(axs[0, -1])
    for ax in axs[1]:
        ax.set_xlabel("t (s)")
    fig.suptitle("MC05 Fig. 4: feature errors (directional vs classical, with and without limits)")
    return save(fig, out / "fig4_features.png")


def figures_for(plane: tuple[int, int]) -> Callable[[Runs, Path], list[Path]]:
    """The function drawing MC05 Figs. 2-4, Fig. 2 in the joint plane ``plane`` (0-based)."""

    def figures(runs: Runs, out: Path) -> list[Path]:
        return [_fig2(runs, out, plane), _fig3(runs, out), _fig4(runs, out)]

    return figures
