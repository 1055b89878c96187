"""The figures of the CM01 gaze experiment: CM01 Figs. 8–13 and the saturation sweep.

* ``fig08_image_and_error.png``: image trajectory, error and ``‖e‖`` of every successful run;
* ``fig09_gpm_axes_1_5.png``, ``fig11_iterative_axes_1_5.png``: normalized axes 1 and 5;
* ``fig10_gpm_control.png``, ``fig12_iterative_control.png``: joint and camera velocities;
* ``fig13_actual_velocities.png``: on the imperfect robot, the command next to the joint
  velocities the robot really has (its odometry: ``(q_{k+1} - q_k)/dt``), lag and delay
  included (CM01 Fig. 13, "actual velocities measured using the robot odometry");
* ``smooth_vs_saturation.png``: iterations to converge of the four iterative variants
  against the controller's velocity saturation, on the imperfect robot's drives.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from redservo.reproduction.base import PAPER_EXACT, Runs
from redservo.reproduction.cm01_gaze_runs import (
    ALPHA_HUGE,
    ALPHA_MODERATE,
    AUTO,
    AUTO_CURRENT,
    GPM,
    IMPERFECT_DELAY,
    IMPERFECT_QDOT_MAX,
    IMPERFECT_TAU,
    ITERATIVE,
    imperfect,
)
from redservo.reproduction.metrics import actual_velocity, succeeded, threshold

__all__ = ["SATURATION_LEVELS", "figures"]

SATURATION_LEVELS: tuple[float | None, ...] = (None, 0.1, 0.05, 0.03, 0.02)
"""Velocity saturations (m/s or rad/s per joint; None: none) of the sweep figure."""


def _velocity_grid(
    runs: Runs, labels: Sequence[str], path: Path, title: str, *, with_alpha: bool = False
) -> Path:
    from redservo.plots.style import _plt, place_legend, save

    plt = _plt()
    names = runs.base.robot.joint_names
    ncol = 3 if with_alpha else 2
    fig, axs = plt.subplots(
        len(labels), ncol, figsize=(4.2 * ncol, 2.4 * len(labels)), squeeze=False
    )
    for row, label in zip(axs, labels, strict=True):
        log = runs[label].log
        for j in range(log.qdot.shape[1]):
            row[0].plot(log.qdot[:, j], lw=1.0, label=f"q̇{j + 1} ({names[j]})")
        row[0].set_title(f"{label}: joint velocities", fontsize=9)
        row[0].set_ylabel("m/s, rad/s")
        for j, comp in enumerate(("vx", "vy", "vz", "ωx", "ωy", "ωz")):
            row[1].plot(log.camera_twist[:, j], lw=1.0, ls="-" if j < 3 else "--", label=comp)
        row[1].set_title(f"{label}: camera velocity", fontsize=9)
        row[1].set_ylabel("m/s, rad/s")
        if with_alpha:
            row[2].semilogy(np.where(log.alpha > 0, log.alpha, np.nan), lw=1.2, color="k")
            row[2].set_title(f"{label}: α", fontsize=9)
        for ax in row:
            ax.set_xlabel("iteration")
        place_legend(row[0], fontsize=6, ncol=2)  # in a corner free of data, else outside
        place_legend(row[1], fontsize=6, ncol=2)
    fig.suptitle(title, fontsize=10)
    return save(fig, path)


_LINE_STYLES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)))
_MARKERS = ("o", "s", "^", "D", "v")


def _axes_style(index: int, count: int) -> dict[str, object]:
    """Line style of the ``index``-th of ``count`` runs: its own dashes and markers, the
    first runs thickest and drawn underneath, so that a run hidden under another shows."""
    return {
        "lw": 1.0 + 1.2 * (count - 1 - index) / max(count - 1, 1),
        "ls": _LINE_STYLES[index % len(_LINE_STYLES)],
        "marker": _MARKERS[index % len(_MARKERS)],
        "markevery": (0.04 * index, 0.2),
        "ms": 4,
        "mfc": "none",
        "zorder": 2 + index,
    }


def _run_end(ax: Any, r: Any, j: int, color: str) -> tuple[float, float] | None:
    """Mark where a run that hit a joint limit ended on the axis ``j`` panel: ``×`` when ``j``
    is the axis that hit (returns that point), a ``|`` (run ends) otherwise (returns None)."""
    k, y = len(r.log) - 1, float(r.log.q_normalized[-1, j])
    axis = int(r.summary["limit_hit"]["axis"])
    if axis == j:
        ax.plot(k, y, "x", color=color, ms=9, mew=2, zorder=10, label="× this axis at its limit")
        return float(k), y
    label = f"| run ends (axis {axis + 1} at its limit)"
    ax.plot(k, y, "|", color=color, ms=12, mew=2, zorder=10, label=label)
    return None


def _annotate_ends(ax: Any, ends: list[tuple[float, float]], j: int, who: list[str]) -> None:
    """One "run ends: axis j at its limit (runs)" next to the last ``×`` of the panel."""
    if not ends:
        return
    x, y = max(ends)
    ax.annotate(
        f"run ends: axis {j + 1} at its limit ({', '.join(who)})",
        (x, y),
        xytext=(10, -16 if y > 0 else 12),
        textcoords="offset points",
        fontsize=8,
        bbox={"fc": "white", "ec": "0.6", "lw": 0.5, "alpha": 0.9},
        zorder=11,
    )


def _axes_figure(runs: Runs, labels: Sequence[str], path: Path, title: str) -> Path:
    """Normalized axes 1 and 5 of several runs, zoomed on the side of the limits they approach.

    The real limits (±1, solid) and the thresholds (±(1 - 2ρ), dashed) are drawn; a run that
    hit a joint limit ends with a ``×`` and "run ends: axis k at its limit" on the panel of
    the axis that hit, a ``|`` on the other panel. The legend is outside, to the right.
    """
    from redservo.plots.style import _plt, save

    plt = _plt()
    thr = threshold(runs.base.limits.rho)
    fig, axs = plt.subplots(2, 1, figsize=(8.5, 6.0), sharex=True)
    for ax, j in zip(axs, (0, 4), strict=True):
        data = np.concatenate([runs[label].log.q_normalized[:, j] for label in labels])
        lo, hi = float(data.min()), float(data.max())
        ends: list[tuple[float, float]] = []
        who: list[str] = []
        for i, label in enumerate(labels):
            r = runs[label]
            style = _axes_style(i, len(labels))
            (line,) = ax.plot(r.log.q_normalized[:, j], label=label, **style)
            if r.outcome == "joint_limit" and r.summary["limit_hit"] is not None:
                end = _run_end(ax, r, j, line.get_color())
                if end is not None:
                    ends.append(end)
                    who.append(label)
        _annotate_ends(ax, ends, j, who)
        marks = [y for y in (-1.0, -thr, thr, 1.0) if lo - 0.25 <= y <= hi + 0.25]
        for y in marks:
            ax.axhline(
                y, color="k" if abs(y) == 1.0 else "0.5", lw=0.8, ls="-" if abs(y) == 1.0 else "--"
            )
        ax.set_ylim(min([lo, *marks]) - 0.02, max([hi, *marks]) + 0.02)
        ax.set_ylabel(f"q{j + 1} (normalized, limits ±1)")
        handles, names = ax.get_legend_handles_labels()
        keep = dict(zip(names, handles, strict=True))  # one entry per label
        ax.legend(
            keep.values(),
            keep.keys(),
            fontsize=8,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            borderaxespad=0.0,
        )
    axs[-1].set_xlabel("iteration")
    axs[0].set_title(title + f"\n(thresholds ±{thr:g} dashed, limits ±1 solid)", fontsize=9)
    return save(fig, path)


def _fig08(runs: Runs, path: Path) -> Path:
    from redservo.plots.style import _plt, save

    plt = _plt()
    exp = runs.experiments["iterative-smooth"]
    log = runs["iterative-smooth"].log
    cam = exp.camera
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(14, 4))
    uv = cam.normalized_to_pixel(log.s[:, :2])
    a.plot(uv[:, 0], uv[:, 1], lw=1.2)
    a.plot(uv[0, 0], uv[0, 1], "o", color="tab:red", ms=5, label="start")
    a.plot(uv[-1, 0], uv[-1, 1], "s", color="tab:green", ms=5, label="end")
    ustar = cam.normalized_to_pixel(exp.task.s_star[:2])
    a.plot(ustar[0], ustar[1], "+", color="k", ms=12, label="P*")
    a.set_xlim(0, cam.width)
    a.set_ylim(cam.height, 0)
    a.set_aspect("equal")
    a.set_xlabel("u (px)")
    a.set_ylabel("v (px)")
    a.legend(fontsize=7)
    a.set_title("(a) image trajectory of the point (iterative-smooth)", fontsize=9)
    b.plot(log.e[:, 0], label="x - x*")
    b.plot(log.e[:, 1], label="y - y*")
    b.axhline(0.0, color="0.5", lw=0.8)
    b.set_xlabel("iteration")
    b.set_ylabel("normalized image units")
    b.legend(fontsize=7)
    b.set_title("(b) error P - P* (iterative-smooth)", fontsize=9)
    for label, r in runs.results.items():
        if succeeded(r) and runs.experiments[label].actuator is None:
            c.semilogy(r.log.error_norm, lw=1.0, label=label)
    c.set_xlabel("iteration")
    c.set_ylabel("‖P - P*‖")
    c.legend(fontsize=6)
    c.set_title("(c) every successful run on the ideal robot", fontsize=9)
    fig.suptitle("CM01 Fig. 8: gazing at a point", fontsize=10)
    return save(fig, path)


def _fig13(runs: Runs, path: Path) -> Path:
    """The command and the odometry velocities of iterative-smooth and iterative, imperfect robot."""
    from redservo.plots.style import _plt, save

    plt = _plt()
    names = runs.base.robot.joint_names
    fig, axs = plt.subplots(2, 2, figsize=(11, 6), sharex=True, sharey="row")
    for row, label in zip(axs, ("iterative-smooth", "iterative"), strict=True):
        run = imperfect(label)
        log, dt = runs[run].log, runs.experiments[run].options.dt
        actual = actual_velocity(log, dt)
        for j in range(log.qdot.shape[1]):
            row[0].plot(log.qdot[:, j], lw=1.0, label=f"q̇{j + 1} ({names[j]})")
            row[1].plot(actual[:, j], lw=1.0, label=f"q̇{j + 1}")
        row[0].set_title(f"{label}: command sent (as Fig. 12)", fontsize=9)
        row[1].set_title(f"{label}: actual velocities, (q_k+1 − q_k)/dt", fontsize=9)
        row[0].set_ylabel("m/s, rad/s")
        row[0].legend(fontsize=6, ncol=2, loc="best")
    for ax in axs[-1]:
        ax.set_xlabel("iteration")
    fig.suptitle(
        f"CM01 Fig. 13: velocities on the imperfect robot (first-order lag τ = "
        f"{IMPERFECT_TAU:g} s, {IMPERFECT_DELAY} period of delay, velocity saturation "
        f"{IMPERFECT_QDOT_MAX:g} m/s or rad/s)",
        fontsize=9,
    )
    return save(fig, path)


def _saturation_sweep(runs: Runs, path: Path) -> Path:
    """Iterations to converge vs the controller's velocity saturation (extra runs)."""
    from redservo.plots.style import _plt, save

    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4))
    x = np.arange(len(SATURATION_LEVELS))
    for label in ITERATIVE:
        exp = runs.experiments[imperfect(label)]
        opts = {**PAPER_EXACT, **({"alpha": ALPHA_MODERATE} if label.endswith("e2") else {})}
        counts = []
        for level in SATURATION_LEVELS:
            r = exp.run(method=label, law_options=opts, qdot_max=level)
            counts.append(r.summary["iterations"] if succeeded(r) else np.nan)
        ax.plot(x, counts, "o-", lw=1.2, ms=4, label=label)
    ax.set_xticks(x, ["none" if v is None else f"{v:g}" for v in SATURATION_LEVELS])
    ax.axvline(SATURATION_LEVELS.index(IMPERFECT_QDOT_MAX), color="0.5", ls="--", lw=0.8)
    ax.set_xlabel("velocity saturation (m/s or rad/s per joint)")
    ax.set_ylabel("iterations to converge")
    ax.set_title(
        "Iterative variants vs the controller's velocity saturation\n(whole command scaled; "
        f"drives with lag τ = {IMPERFECT_TAU:g} s and one period of delay; dashed: the claim's "
        "set-up)",
        fontsize=9,
    )
    ax.legend(fontsize=7)
    return save(fig, path)


def figures(runs: Runs, out_dir: Path) -> list[Path]:
    """Draw CM01 Figs. 8-13 and the saturation sweep into ``out_dir``."""
    gpm_labels = ["classical", *GPM.values(), AUTO]
    return [
        _fig08(runs, out_dir / "fig08_image_and_error.png"),
        _axes_figure(
            runs,
            gpm_labels,
            out_dir / "fig09_gpm_axes_1_5.png",
            "CM01 Fig. 9: gradient projection, axes 1 and 5",
        ),
        _velocity_grid(
            runs,
            [GPM[ALPHA_MODERATE], GPM[ALPHA_HUGE], AUTO, AUTO_CURRENT],
            out_dir / "fig10_gpm_control.png",
            f"CM01 Fig. 10: control laws for α = {ALPHA_MODERATE:g}, α = {ALPHA_HUGE:g} and "
            "automatic α (our critical-axis rule, and CM01's current-position rule)",
            with_alpha=True,
        ),
        _axes_figure(
            runs,
            ITERATIVE,
            out_dir / "fig11_iterative_axes_1_5.png",
            "CM01 Fig. 11: iterative approach, axes 1 and 5",
        ),
        _velocity_grid(
            runs,
            ITERATIVE,
            out_dir / "fig12_iterative_control.png",
            "CM01 Fig. 12: control laws of the iterative approach",
        ),
        _fig13(runs, out_dir / "fig13_actual_velocities.png"),
        _saturation_sweep(runs, out_dir / "smooth_vs_saturation.png"),
    ]
