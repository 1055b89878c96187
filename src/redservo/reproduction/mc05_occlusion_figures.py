"""The figures of the MC05 occlusion experiment (Figs. 5-7); the experiment is
:mod:`~redservo.reproduction.mc05_occlusion`.

* ``fig5_avoidance_velocities.png``: the camera-frame translation of the avoidance
  (:func:`~redservo.reproduction.mc05.avoidance_split`), classical projector and directional;
* ``fig6_image_phases.png``: the image at the main phases (dots and the sphere's disc);
* ``fig7_features.png``: the task feature errors, ``‖e1‖`` against the classical exponential,
  and the image clearance between the dots and the disc.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from redservo.records.verdict import outcome_text
from redservo.reproduction.base import Runs
from redservo.reproduction.mc05 import (
    FEATURES,
    avoidance_split,
    clearance,
    occluder_disc,
    pyplot,
    target_image,
)

__all__ = ["NEAR_PX", "figures"]

NEAR_PX = 100.0
"""Clearance (px) below which Fig. 7 shades the time as 'the sphere is near the dots'."""
CLASSICAL = "classical projector"
DIRECTIONAL = "directional"
NONE = "no avoidance"


def _fig5(runs: Runs, out: Path) -> Path:
    from redservo.plots.style import place_legend, save

    plt = pyplot()
    fig, axs = plt.subplots(2, 1, figsize=(7, 5.2), sharex=True, sharey=True)
    for ax, label, tag in ((axs[0], CLASSICAL, "a"), (axs[1], DIRECTIONAL, "b")):
        split = avoidance_split(runs[label], runs.experiments[label])
        t = runs[label].log.t
        for c, name, color in (
            (0, "v_x", "tab:blue"),
            (1, "v_y", "tab:green"),
            (2, "v_z", "tab:red"),
        ):
            ax.plot(t, split.twist2[:, c], color=color, lw=1.3, label=name)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel("m/s")
        ax.set_title(f"({tag}) avoidance translation, camera frame — {label}", fontsize=9)
        place_legend(ax, fontsize=7)
    axs[1].set_xlabel("t (s)")
    fig.suptitle("MC05 Fig. 5: camera translation of the avoidance term, classical vs directional")
    return save(fig, out / "fig5_avoidance_velocities.png")


def _phase_indices(runs: Runs) -> list[int]:
    """Iterations shown in Fig. 6: start, the no-avoidance occlusion, the classical one, later, end."""
    n_none = len(runs[NONE].log) - 1
    n_cl = len(runs[CLASSICAL].log) - 1
    n_dir = len(runs[DIRECTIONAL].log) - 1
    mid = min(n_dir, 2 * n_cl + 10)
    idx = sorted({0, n_none, n_cl, mid, n_dir})
    return idx


def _fig6(runs: Runs, out: Path) -> Path:
    from redservo.plots.style import save

    plt = pyplot()
    idx = _phase_indices(runs)
    exp = runs.experiments[DIRECTIONAL]
    cam = exp.camera
    fig, axs = plt.subplots(2, len(idx), figsize=(2.6 * len(idx), 4.6), squeeze=False)
    for row, (label, tag) in enumerate(((CLASSICAL, "a"), (DIRECTIONAL, "b"))):
        res, e = runs[label], runs.experiments[label]
        for col, i in enumerate(idx):
            ax = axs[row, col]
            ax.set_xlim(0, cam.width)
            ax.set_ylim(cam.height, 0)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            t = i * e.options.dt
            ax.set_title(f"({tag}) t = {t:.2f} s", fontsize=8)
            if i >= len(res.log):
                ax.text(
                    0.5,
                    0.5,
                    "stopped:\n" + textwrap.fill(outcome_text(res.summary), 22),
                    ha="center",
                    va="center",
                    transform=ax.transAxes,
                    fontsize=8,
                )
                continue
            q = res.log.q[i]
            uv = cam.normalized_to_pixel(target_image(e, q, t))
            ax.plot(uv[:, 0], uv[:, 1], "o", color="k", ms=4)
            disc = occluder_disc(e, q, t)
            if disc is not None:
                c = cam.normalized_to_pixel(disc[0])
                ax.add_patch(plt.Circle((c[0], c[1]), disc[1] * cam.px, color="tab:red", alpha=0.5))
        axs[row, 0].set_ylabel(label, fontsize=8)
    fig.suptitle("MC05 Fig. 6: image at the main phases (dots: target; disc: occluding sphere)")
    return save(fig, out / "fig6_image_phases.png")


def _fig7(runs: Runs, out: Path) -> Path:
    from redservo.plots.style import save

    plt = pyplot()
    fig, axs = plt.subplots(2, 3, figsize=(12, 5.4), sharex=True)
    styles = {DIRECTIONAL: ("tab:blue", "-"), CLASSICAL: ("tab:green", "-"), NONE: ("0.3", ":")}
    exp = runs.experiments[DIRECTIONAL]
    px = exp.camera.px
    clear = {label: clearance(runs.experiments[label], runs[label]) for label in styles}
    t_dir = runs[DIRECTIONAL].log.t
    near = clear[DIRECTIONAL] * px < NEAR_PX
    panels = [axs[0, 0], axs[0, 1], axs[1, 0], axs[1, 1]]
    for i, ax in enumerate(panels):
        for label, (color, ls) in styles.items():
            log = runs[label].log
            ax.plot(log.t, log.e[:, i], color=color, ls=ls, lw=1.3, label=label)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_title(f"{FEATURES[i]} − {FEATURES[i]}*", fontsize=9)
    ax = axs[0, 2]
    for label, (color, ls) in styles.items():
        log = runs[label].log
        ax.semilogy(log.t, log.error_norm, color=color, ls=ls, lw=1.3, label=label)
    lam, dt = exp.options.constant_lam, exp.options.dt
    e0 = float(runs[DIRECTIONAL].log.error_norm[0])
    ax.semilogy(
        t_dir,
        e0 * (1 - lam * dt) ** np.arange(len(t_dir)),
        color="k",
        lw=0.7,
        ls="--",
        label="(1 − λ dt)^k ‖e0‖",
    )
    ax.set_title("‖e1‖", fontsize=9)
    ax.legend(fontsize=6)
    ax = axs[1, 2]
    for label, (color, ls) in styles.items():
        c = np.where(np.isfinite(clear[label]), clear[label] * px, np.nan)
        ax.plot(runs[label].log.t, c, color=color, ls=ls, lw=1.3, label=label)
    ax.axhline(0.0, color="tab:red", lw=0.8)
    ax.set_ylim(-20, 400)
    ax.set_title("clearance dot–disc (px)", fontsize=9)
    for ax in axs.flat:
        ax.fill_between(
            t_dir,
            0,
            1,
            where=near,
            transform=ax.get_xaxis_transform(),
            color="tab:red",
            alpha=0.1,
            step="post",
        )
    axs[0, 0].legend(fontsize=7)
    for ax in axs[1]:
        ax.set_xlabel("t (s)")
    fig.suptitle(
        f"MC05 Fig. 7: task feature errors (shaded: sphere within {NEAR_PX:g} px of a dot, "
        "directional run)"
    )
    return save(fig, out / "fig7_features.png")


def figures(runs: Runs, out: Path) -> list[Path]:
    """Draw MC05 Figs. 5-7 into ``out``."""
    return [_fig5(runs, out), _fig6(runs, out), _fig7(runs, out)]
